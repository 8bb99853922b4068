// The baked asset end to end on real data: import -> bake -> .mrg -> load -> every DAG valid and
// 100 random cuts per mesh watertight and overlap-free on the stored (quantized) geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "lod_meshes.h"
#include "mirage/io/import.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/verify.h"
#include "test_support.h"

using namespace mirage;

namespace {

void bakeSaveLoadAndCut(const std::filesystem::path& input, int cutsPerMesh) {
  auto scene = io::importScene(input);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto baked = lod::bakeLodAsset(*scene, {});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  for (size_t i = 0; i < scene->meshes.size(); ++i) // the builder's map is the key lookup's
    EXPECT_EQ(baked->sourceClusters[i], lod::sourceTriangleClusters(scene->meshes[i], baked->dags[i])) << i;
  auto path = test::tempDir("lodasset") / "scene.mrg";
  ASSERT_TRUE(lod::saveLodAsset(path.string(), *baked).ok());
  auto loaded = lod::loadLodAsset(path.string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_EQ(loaded->dags.size(), scene->meshes.size());
  EXPECT_EQ(loaded->scene.instances.size(), scene->instances.size());
  std::mt19937 rng(3);
  for (size_t i = 0; i < loaded->dags.size(); ++i) {
    const lod::ClusterDag& dag = loaded->dags[i];
    ASSERT_TRUE(lod::verifyDag(dag).ok()) << "mesh " << i << ": " << lod::verifyDag(dag).error().message;
    Mesh reference = lod::levelZeroMesh(dag);
    float maxError = 0.0f;
    for (const lod::Group& g : dag.groups) maxError = std::max(maxError, g.bounds.error);
    for (int c = 0; c < cutsPerMesh; ++c) {
      float tau = maxError * 1.05f * std::pow(1e-4f, std::uniform_real_distribution<float>(0.0f, 1.0f)(rng));
      std::vector<uint32_t> cut = lod::selectCut(dag, tau);
      Status s = lod::verifyCut(dag, cut, reference);
      ASSERT_TRUE(s.ok()) << input << " mesh " << i << " tau " << tau << ": " << s.error().message;
      if (c % 25 == 0) {
        // The cut as a plain mesh (the discrete-LOD baseline): the same triangles, compact vertices.
        Mesh m = lod::cutMesh(dag, cut);
        size_t triangles = 0;
        for (uint32_t id : cut) triangles += dag.clusters[id].triangleCount;
        EXPECT_EQ(m.triangleCount(), triangles);
        EXPECT_LE(m.vertexCount(), dag.vertexPosition.size());
        EXPECT_EQ(m.normals.size(), dag.normals.empty() ? 0 : m.vertexCount());
        EXPECT_EQ(m.uv0.size(), dag.uv0.empty() ? 0 : m.vertexCount());
        EXPECT_TRUE(std::all_of(m.indices.begin(), m.indices.end(), [&](uint32_t v) { return v < m.vertexCount(); }));
      }
    }
    // Root is small: a few clusters or under 1% of the input.
    EXPECT_TRUE(dag.roots.size() <= 8 || dag.rootTriangles() * 100 < dag.inputTriangles) << "mesh " << i;
  }
}

} // namespace

TEST(LodAsset, DamagedHelmetWithUvSeams) {
  MIRAGE_REQUIRE_DATA(path, "khronos-damaged-helmet/DamagedHelmet.glb");
  bakeSaveLoadAndCut(path, 100);
}

TEST(LodAsset, BunnyScan) {
  MIRAGE_REQUIRE_DATA(path, "stanford-bunny/bun_zipper.ply");
  bakeSaveLoadAndCut(path, 100);
}

TEST(LodAsset, CorruptFileIsAClearError) {
  auto dir = test::tempDir("lodcorrupt");
  auto missing = lod::loadLodAsset((dir / "missing.mrg").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("missing.mrg"), std::string::npos);
}

// saveLodAsset reads the complete file back before it takes the name: a file its readers would
// reject is never published, and nothing is left behind.
TEST(LodAsset, SaveRefusesAFileThatDoesNotReadBack) {
  Scene scene;
  scene.source = "blob";
  scene.meshes.push_back(lodtest::makeBlob(2, 5));
  scene.materials.push_back(Material{});
  scene.instances.push_back({0, glm::mat4(1.0f)});
  auto baked = lod::bakeLodAsset(scene, {});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  auto dir = test::tempDir("lodreadback");
  auto good = dir / "good.mrg";
  ASSERT_TRUE(lod::saveLodAsset(good.string(), *baked).ok());
  EXPECT_TRUE(lod::loadLodAsset(good.string()).ok());
  baked->dags[0].clusterIndices[0] = 255; // encodes, but no reader accepts it
  auto bad = dir / "bad.mrg";
  Status s = lod::saveLodAsset(bad.string(), *baked);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("bad.mrg"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("local index out of range"), std::string::npos) << s.error().message;
  EXPECT_EQ(s.error().message.rfind("bad.mrg"), s.error().message.find("bad.mrg")) << "the file is named once";
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1) << "only good.mrg may exist";
}
