// The 'CDAG' encoding: decode(encode(dag)) keeps the structure exactly, moves positions by at most
// half a grid step, stays a valid DAG whose cuts are watertight, and rejects corrupt bytes cleanly.
#include <gtest/gtest.h>

#include <random>

#include "lod_meshes.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/verify.h"

using namespace mirage;
using namespace mirage::lod;

namespace {

// The original mesh with every vertex moved to its decoded (quantized) position: what cuts of the
// decoded DAG must cover.
Mesh quantizedOriginal(const Mesh& original, const ClusterDag& decoded) {
  Mesh m = original;
  for (size_t i = 0; i < m.positions.size(); ++i) m.positions[i] = decoded.positions[decoded.vertexPosition[i]];
  return m;
}

} // namespace

TEST(DagCodec, RoundTripKeepsStructureAndCuts) {
  for (Mesh mesh : {lodtest::makeBlob(4, 3), lodtest::makeTerrain(60, 5), lodtest::makeSeamBlob(4, 7)}) {
    auto dag = buildClusterDag(mesh);
    ASSERT_TRUE(dag.ok()) << dag.error().message;
    std::vector<uint8_t> bytes = encodeDag(*dag);
    auto back = decodeDag(bytes, "test.mrg");
    ASSERT_TRUE(back.ok()) << back.error().message;
    const ClusterDag& a = *dag;
    const ClusterDag& b = *back;
    ASSERT_EQ(a.clusters.size(), b.clusters.size());
    EXPECT_EQ(a.clusterVertices, b.clusterVertices);
    EXPECT_EQ(a.clusterIndices, b.clusterIndices);
    EXPECT_EQ(a.groupChildren, b.groupChildren);
    EXPECT_EQ(a.groupParents, b.groupParents);
    EXPECT_EQ(a.roots, b.roots);
    EXPECT_EQ(a.vertexPosition, b.vertexPosition);
    EXPECT_EQ(a.inputTriangles, b.inputTriangles);
    ASSERT_EQ(a.positions.size(), b.positions.size());
    Bounds box;
    for (auto p : a.positions) box.add(p);
    float step = std::max({box.extent().x, box.extent().y, box.extent().z}) / 65535.0f;
    for (size_t i = 0; i < a.positions.size(); ++i) {
      glm::vec3 d = glm::abs(a.positions[i] - b.positions[i]);
      ASSERT_LE(std::max({d.x, d.y, d.z}), step * 0.52f); // half a step plus float rounding
    }
    for (size_t i = 0; i < a.clusters.size(); ++i) {
      EXPECT_EQ(a.clusters[i].level, b.clusters[i].level);
      EXPECT_EQ(a.clusters[i].group, b.clusters[i].group);
      EXPECT_EQ(a.clusters[i].generatingGroup, b.clusters[i].generatingGroup);
      EXPECT_GE(b.clusters[i].self.error, a.clusters[i].self.error); // conservative
      EXPECT_GE(b.clusters[i].parent.error, a.clusters[i].parent.error);
    }
    for (size_t i = 0; i < a.normals.size(); i += 7) EXPECT_GT(glm::dot(a.normals[i], b.normals[i]), 0.9999f);
    for (size_t i = 0; i < a.uv0.size(); ++i) EXPECT_EQ(a.uv0[i], b.uv0[i]);

    EXPECT_TRUE(verifyDag(b).ok()) << verifyDag(b).error().message;
    Mesh moved = quantizedOriginal(mesh, b);
    std::mt19937 rng(11);
    float maxError = 0.0f;
    for (const Group& g : b.groups) maxError = std::max(maxError, g.bounds.error);
    for (int t = 0; t < 40; ++t) {
      float tau = std::uniform_real_distribution<float>(0.0f, maxError * 1.1f)(rng);
      auto cut = selectCut(b, tau);
      Status s = verifyCut(b, cut, moved);
      ASSERT_TRUE(s.ok()) << "tau " << tau << ": " << s.error().message;
    }
  }
}

TEST(DagCodec, EncodingIsCompact) {
  Mesh mesh = lodtest::makeBlob(5, 1); // 20k triangles
  auto dag = buildClusterDag(mesh);
  ASSERT_TRUE(dag.ok());
  std::vector<uint8_t> bytes = encodeDag(*dag);
  double perTriangle = double(bytes.size()) / double(mesh.triangleCount());
  // Raw (before the container's zstd): the DAG holds ~2x the input triangles at 3 index bytes each.
  EXPECT_LT(perTriangle, 24.0) << "bytes per input triangle before zstd";
}

TEST(DagCodec, CorruptBytesAreRejectedNotCrashed) {
  auto dag = buildClusterDag(lodtest::makeBlob(2, 9));
  ASSERT_TRUE(dag.ok());
  std::vector<uint8_t> bytes = encodeDag(*dag);
  for (size_t n = 0; n < bytes.size(); n += std::max<size_t>(1, bytes.size() / 400)) {
    auto r = decodeDag(std::span(bytes.data(), n), "cut.mrg");
    EXPECT_FALSE(r.ok()) << "truncated to " << n;
  }
  std::mt19937 rng(5);
  for (int i = 0; i < 2000; ++i) {
    std::vector<uint8_t> bad = bytes;
    int flips = 1 + int(rng() % 4);
    for (int f = 0; f < flips; ++f) bad[rng() % bad.size()] ^= uint8_t(1u << (rng() % 8));
    auto r = decodeDag(bad, "flip.mrg"); // must return, either way
    if (r.ok()) (void)verifyDag(*r);     // and a decoded DAG must be safe to verify
  }
  std::vector<uint8_t> wrongVersion = bytes;
  wrongVersion[0] = 99;
  auto r = decodeDag(wrongVersion, "v.mrg");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("version 99"), std::string::npos);
}
