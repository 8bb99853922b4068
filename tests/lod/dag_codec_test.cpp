// The 'CDAG' encoding: decode(encode(dag)) keeps the structure exactly, moves positions by at most
// half a grid step, stays a valid DAG whose cuts are watertight, and rejects corrupt bytes cleanly.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <tuple>

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

namespace {

// The header's position fields: u32 codec version, u64 input triangles, u32 bits, origin, step.
uint32_t encodedBits(const std::vector<uint8_t>& bytes) {
  uint32_t bits = 0;
  std::memcpy(&bits, bytes.data() + 12, 4);
  return bits;
}
float encodedStep(const std::vector<uint8_t>& bytes) {
  float step = 0.0f;
  std::memcpy(&step, bytes.data() + 28, 4);
  return step;
}

// Decoded positions: every one within half a grid step (plus the float rounding of a coordinate of
// that magnitude) of the original, and distinct ones still distinct (the topology is kept).
void expectPositionsRoundTrip(const std::vector<glm::vec3>& original, const std::vector<uint8_t>& bytes,
                              const ClusterDag& decoded, const std::string& what) {
  ASSERT_EQ(original.size(), decoded.positions.size()) << what;
  uint32_t bits = encodedBits(bytes);
  float magnitude = 0.0f;
  for (glm::vec3 p : original) magnitude = std::max({magnitude, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  float tolerance = bits == 32 ? 0.0f : 0.5f * encodedStep(bytes) + std::ldexp(magnitude, -22);
  for (size_t i = 0; i < original.size(); ++i) {
    glm::vec3 d = glm::abs(original[i] - decoded.positions[i]);
    ASSERT_LE(std::max({d.x, d.y, d.z}), tolerance) << what << ", position " << i << " at " << bits << " bits";
  }
  std::vector<std::array<float, 3>> sorted;
  for (glm::vec3 p : decoded.positions) sorted.push_back({p.x + 0.0f, p.y + 0.0f, p.z + 0.0f});
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end()) << what << ": two positions fused";
}

} // namespace

// Random boxes (extents 2^-12..2^12, up to 2^10 away from the origin) with points on every face of
// the box, at every requested depth: the encoder's grid must hold its own top coordinate (a float
// step rounded down put it one step past the grid in about 10 % of boxes at 23 bits), and what it
// writes must decode.
TEST(DagCodec, QuantizerKeepsEveryBoxOnItsGridAtEveryDepth) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), expo(-12.0f, 12.0f), offset(-10.0f, 10.0f);
  std::vector<uint32_t> depths;
  for (uint32_t b = 16; b <= 24; ++b) depths.push_back(b);
  depths.push_back(32); // raw floats
  for (uint32_t bits : depths) {
    for (int trial = 0; trial < 400; ++trial) {
      glm::vec3 extent = glm::vec3(std::exp2(expo(rng))) * glm::vec3(unit(rng), unit(rng), unit(rng));
      extent[trial % 3] = std::exp2(expo(rng)); // the largest axis sets the step
      glm::vec3 origin(std::copysign(std::exp2(offset(rng)), unit(rng) - 0.5f), std::exp2(offset(rng)) * -0.5f,
                       unit(rng));
      ClusterDag dag;
      dag.positions = {origin, origin + extent};
      for (int i = 0; i < 40; ++i) {
        glm::vec3 t(unit(rng), unit(rng), unit(rng));
        t[i % 3] = float(i & 1); // on a face of the box
        dag.positions.push_back(origin + t * extent);
      }
      std::sort(dag.positions.begin(), dag.positions.end(),
                [](glm::vec3 a, glm::vec3 b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); });
      dag.positions.erase(std::unique(dag.positions.begin(), dag.positions.end()), dag.positions.end());
      for (uint32_t i = 0; i < dag.positions.size(); ++i) dag.vertexPosition.push_back(i);
      DagEncodeOptions options;
      options.positionBits = bits;
      std::vector<uint8_t> bytes = encodeDag(dag, options);
      std::string what = "bits " + std::to_string(bits) + " trial " + std::to_string(trial);
      EXPECT_GE(encodedBits(bytes), bits) << what;
      auto back = decodeDag(bytes, "grid.mrg");
      ASSERT_TRUE(back.ok()) << what << ": " << back.error().message;
      expectPositionsRoundTrip(dag.positions, bytes, *back, what);
      if (bits == 32) {
        EXPECT_EQ(back->positions, dag.positions) << what;
      }
    }
  }
}

// Coordinates near the float range (the grid's extent or slack would overflow) and a mesh far from
// the origin for its size (float rounding beyond the step) still decode, exactly or on a grid.
TEST(DagCodec, ExtremeCoordinatesRoundTrip) {
  for (std::vector<glm::vec3> positions :
       {std::vector<glm::vec3>{{-3e38f, 0, 0}, {3e38f, 1, 2}, {0, -3e38f, 3e38f}},
        std::vector<glm::vec3>{{1e6f, 1e6f, 1e6f}, {1e6f + 0.0625f, 1e6f, 1e6f}, {1e6f, 1e6f + 0.125f, 1e6f}}}) {
    ClusterDag dag;
    dag.positions = positions;
    dag.vertexPosition = {0, 1, 2};
    std::vector<uint8_t> bytes = encodeDag(dag);
    auto back = decodeDag(bytes, "far.mrg");
    ASSERT_TRUE(back.ok()) << back.error().message;
    expectPositionsRoundTrip(dag.positions, bytes, *back, "extreme");
  }
}

// A mesh whose every vertex has a distinct twin 4.2e-7 away over a 2.72 extent (as one mesh of a
// real diorama): the encoder needs 23+ bits or raw floats, the decoded DAG keeps every position
// apart, stays valid, and its cuts stay watertight.
TEST(DagCodec, NearCoincidentVerticesRoundTrip) {
  for (float shift : {4.2e-7f, 1e-7f, 4.2e-7f * 0.5f}) {
    Mesh terrain = lodtest::makeTerrain(24, 3);
    Bounds box;
    for (glm::vec3 p : terrain.positions) box.add(p);
    float scale = 2.72f / std::max({box.extent().x, box.extent().y, box.extent().z});
    Mesh mesh = terrain;
    for (glm::vec3& p : mesh.positions) p = (p - box.min) * scale + glm::vec3(0.3f, -1.0f, 0.7f);
    uint32_t n = uint32_t(mesh.positions.size());
    auto away = [shift](float v) { // at least one float step: below it the twins would be one position
      float t = v + shift;
      return t != v ? t : std::nextafter(v, 1e30f);
    };
    for (uint32_t i = 0; i < n; ++i) {
      glm::vec3 p = mesh.positions[i];
      mesh.positions.push_back({away(p.x), p.y, away(p.z)});
    }
    if (!mesh.normals.empty()) mesh.normals.insert(mesh.normals.end(), terrain.normals.begin(), terrain.normals.end());
    if (!mesh.uv0.empty()) mesh.uv0.insert(mesh.uv0.end(), terrain.uv0.begin(), terrain.uv0.end());
    size_t indices = mesh.indices.size();
    for (size_t i = 0; i < indices; ++i) mesh.indices.push_back(mesh.indices[i] + n);
    auto dag = buildClusterDag(mesh);
    ASSERT_TRUE(dag.ok()) << dag.error().message;
    ASSERT_EQ(dag->positions.size(), size_t(2 * n)) << "the twins must be distinct welded positions";
    std::vector<uint8_t> bytes = encodeDag(*dag);
    EXPECT_GE(encodedBits(bytes), 23u);
    auto back = decodeDag(bytes, "twins.mrg");
    ASSERT_TRUE(back.ok()) << "shift " << shift << ": " << back.error().message;
    expectPositionsRoundTrip(dag->positions, bytes, *back, "shift " + std::to_string(shift));
    EXPECT_EQ(dag->clusterIndices, back->clusterIndices);
    ASSERT_TRUE(verifyDag(*back).ok()) << verifyDag(*back).error().message;
    Mesh moved = quantizedOriginal(mesh, *back);
    for (float tau : {0.0f, 1e-4f, 1e-2f, 1.0f}) {
      Status s = verifyCut(*back, selectCut(*back, tau), moved);
      EXPECT_TRUE(s.ok()) << "shift " << shift << " tau " << tau << ": " << s.error().message;
    }
  }
}

// Damage the encoder faithfully writes (checksums would be valid in a file) must be rejected by the
// decoder itself, so no reader indexes with it: meshopt_computeClusterBounds aborted on an
// out-of-range local index that only `verify` checked.
TEST(DagCodec, DecodeRejectsStructuralDamage) {
  auto built = buildClusterDag(lodtest::makeBlob(3, 4));
  ASSERT_TRUE(built.ok());
  ASSERT_GT(built->groups.size(), 1u);
  auto expectRejected = [](const ClusterDag& bad, const std::string& problem) {
    auto r = decodeDag(encodeDag(bad), "bad.mrg");
    ASSERT_FALSE(r.ok()) << problem << " was accepted";
    EXPECT_NE(r.error().message.find(problem), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  };
  ClusterDag bad = *built;
  bad.clusterIndices[7] = uint8_t(bad.clusters[0].vertexCount); // one past cluster 0's vertices
  expectRejected(bad, "local index out of range");
  bad = *built;
  bad.roots.back() = 0; // a level-0 cluster that has a group
  expectRejected(bad, "root list names a non-root cluster");
  bad = *built;
  std::swap(bad.groupChildren.front(), bad.groupChildren.back()); // children of other groups
  expectRejected(bad, "does not point back");
  bad = *built;
  bad.groups[0].level = bad.clusters[bad.groupParents[bad.groups[0].parentOffset]].level; // a level loop
  expectRejected(bad, "not one level above");
}
