// Invariant tests for the cluster-LOD DAG: structure, and >= 100 LOCALCUT thresholds per mesh
// giving watertight, overlap-free cuts. Meshes are generated here (plus the bunny when present).
#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "lod_meshes.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/verify.h"
#include "test_scenes.h"
#include "test_support.h"

namespace mirage::lod {
namespace {

using lodtest::makeBlob;
using lodtest::makeRandomMesh;
using lodtest::makeSeamBlob;
using lodtest::makeTerrain;

// Thresholds: every distinct group error exactly (the <= / < edge of LOCALCUT), values between
// them, log-uniform random ones, zero and beyond the largest error.
std::vector<float> thresholds(const ClusterDag& dag, size_t count, uint32_t seed) {
  std::vector<float> errors;
  for (const Group& g : dag.groups) errors.push_back(g.bounds.error);
  std::sort(errors.begin(), errors.end());
  errors.erase(std::unique(errors.begin(), errors.end()), errors.end());
  std::vector<float> out{0.0f, std::numeric_limits<float>::max()};
  std::mt19937 rng(seed);
  for (size_t i = 0; i < errors.size() && out.size() < count / 2; ++i) {
    size_t j = errors.size() <= count / 4 ? i : rng() % errors.size();
    out.push_back(errors[j]);
    if (j + 1 < errors.size()) out.push_back(0.5f * (errors[j] + errors[j + 1]));
  }
  float lo = errors.empty() ? 1e-6f : std::max(errors.front(), 1e-9f), hi = errors.empty() ? 1.0f : errors.back();
  std::uniform_real_distribution<float> u(std::log(lo) - 1.0f, std::log(hi) + 1.0f);
  while (out.size() < count) out.push_back(std::exp(u(rng)));
  return out;
}

bool rootIsSmall(const ClusterDag& dag) {
  return dag.roots.size() <= 4 || double(dag.rootTriangles()) < 0.01 * double(dag.inputTriangles);
}

// Builds, checks the structure, and verifies `count` cuts; returns the DAG for further checks.
ClusterDag buildAndVerify(const Mesh& mesh, size_t count = 120, BuildConfig cfg = {}) {
  Result<ClusterDag> dag = buildClusterDag(mesh, cfg);
  EXPECT_TRUE(dag.ok()) << (dag.ok() ? "" : dag.error().message);
  if (!dag.ok()) return {};
  Status s = verifyDag(*dag);
  EXPECT_TRUE(s.ok()) << mesh.name << ": " << (s.ok() ? "" : s.error().message);
  for (float t : thresholds(*dag, count, 7)) {
    std::vector<uint32_t> cut = selectCut(*dag, t);
    Status c = verifyCut(*dag, cut, mesh);
    EXPECT_TRUE(c.ok()) << mesh.name << " threshold " << t << ": " << (c.ok() ? "" : c.error().message);
    if (!c.ok()) break;
  }
  return std::move(dag).value();
}

TEST(ClusterDag, ClosedBlobCutsAreWatertight) {
  Mesh mesh = makeBlob(5, 1); // 20480 triangles
  ClusterDag dag = buildAndVerify(mesh);
  EXPECT_GE(dag.levelCount(), 5u);
  EXPECT_TRUE(rootIsSmall(dag)) << dag.roots.size() << " roots";
  EXPECT_EQ(selectCut(dag, 0.0f).size(), dag.levels[0].clusters); // threshold 0 = full resolution
}

TEST(ClusterDag, OpenTerrainSimplifiesItsBorderAndEndsSmall) {
  Mesh mesh = makeTerrain(100, 2); // 20000 triangles, open border
  ClusterDag dag = buildAndVerify(mesh);
  EXPECT_TRUE(rootIsSmall(dag)) << dag.roots.size() << " roots, " << dag.rootTriangles() << " triangles";
}

TEST(ClusterDag, UvSeamsDoNotBlockSimplification) {
  Mesh mesh = makeSeamBlob(5, 3);
  ClusterDag dag = buildAndVerify(mesh);
  EXPECT_TRUE(rootIsSmall(dag)) << dag.roots.size() << " roots";
  // Attributes are carried: every cluster vertex is an input vertex with its own UV.
  EXPECT_EQ(dag.uv0.size(), mesh.uv0.size());
}

TEST(ClusterDag, UvSphereWithPolesAndSeam) {
  Mesh mesh = test::makeSphere(1.0f, 64, 96); // degenerate pole triangles, a UV seam
  ClusterDag dag = buildAndVerify(mesh);
  // North-pole triangles weld away (sin(0) == 0); the south pole's sin(pi) != 0 keeps them apart.
  EXPECT_EQ(dag.inputTriangles, 64u * 96u * 2u - 96u);
  EXPECT_TRUE(rootIsSmall(dag));
}

TEST(ClusterDag, Bunny) {
  MIRAGE_REQUIRE_DATA(path, "stanford-bunny/bun_zipper.ply");
  std::optional<Mesh> mesh = lodtest::readAsciiPly(path);
  ASSERT_TRUE(mesh.has_value());
  ClusterDag dag = buildAndVerify(*mesh, 100);
  EXPECT_TRUE(rootIsSmall(dag)) << dag.roots.size() << " roots";
}

// Tunnels keep a tube of triangles under topology-keeping collapses; the stuck groups' vertex
// clustering must still take the DAG to one root, within the verifier's rules.
TEST(ClusterDag, TunnelsStillEndInOneRoot) {
  Mesh mesh = lodtest::makeDrilledSlab();
  ClusterDag dag = buildAndVerify(mesh);
  EXPECT_EQ(dag.roots.size(), 1u) << dag.rootTriangles() << " root triangles";
}

TEST(ClusterDag, DragonEndsInOneRoot) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply"); // genus about 55 (scan tunnels)
  std::optional<Mesh> mesh = lodtest::readAsciiPly(path);
  ASSERT_TRUE(mesh.has_value());
  for (float normalWeight : {0.0f, BuildConfig{}.normalWeight}) {
    BuildConfig cfg;
    cfg.normalWeight = normalWeight;
    Result<ClusterDag> dag = buildClusterDag(*mesh, cfg);
    ASSERT_TRUE(dag.ok());
    Status s = verifyDag(*dag);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    EXPECT_EQ(dag->roots.size(), 1u) << "normal weight " << normalWeight << ": " << dag->rootTriangles()
                                     << " root triangles";
  }
}

TEST(ClusterDag, ClustersRespectLimits) {
  BuildConfig cfg;
  cfg.clusterTriangles = 64;
  cfg.clusterVertices = 64;
  cfg.groupClusters = 4;
  Mesh mesh = makeBlob(4, 5);
  ClusterDag dag = buildAndVerify(mesh, 100, cfg);
  for (const Cluster& c : dag.clusters) {
    EXPECT_LE(c.triangleCount, 64u);
    EXPECT_LE(c.vertexCount, 64u);
  }
}

TEST(ClusterDag, DegenerateInputBuilds) {
  Mesh mesh = makeBlob(3, 4);
  uint32_t n = uint32_t(mesh.positions.size());
  mesh.indices.insert(mesh.indices.end(), {0, 0, 1, 2, 2, 2});                              // zero area
  mesh.indices.insert(mesh.indices.end(), mesh.indices.begin(), mesh.indices.begin() + 30); // duplicates
  mesh.positions.push_back({0.0f, 3.0f, 0.0f});                                             // fin apex
  mesh.indices.insert(mesh.indices.end(), {mesh.indices[0], mesh.indices[1], n});           // non-manifold edge
  mesh.positions.push_back({9.0f, 9.0f, 9.0f});                                             // isolated
  Mesh other = makeTerrain(10, 9);                                                          // disconnected
  uint32_t base = uint32_t(mesh.positions.size());
  for (glm::vec3 p : other.positions) mesh.positions.push_back(p + glm::vec3(5.0f, 0.0f, 0.0f));
  for (uint32_t i : other.indices) mesh.indices.push_back(base + i);
  mesh.normals.clear();
  ClusterDag dag = buildAndVerify(mesh);
  EXPECT_EQ(dag.inputTriangles, 1280u + 1u + 200u);
  EXPECT_TRUE(rootIsSmall(dag));
}

// The source-triangle map the builder records (level-0 split order, clean's first copies) must be
// the one the key lookup finds, for the single-set path and the chunked (Morton) one, with
// degenerate and duplicate (either winding) triangles.
TEST(ClusterDag, BuilderSourceMapEqualsTheKeyLookup) {
  for (uint32_t subdivisions : {3u, 5u}) {
    Mesh mesh = makeBlob(subdivisions, 7);
    mesh.indices.insert(mesh.indices.end(), {0, 0, 1, 2, 3, 2});
    for (size_t t = 0; t < 40; t += 4)
      mesh.indices.insert(mesh.indices.end(), {mesh.indices[t * 3 + 2], mesh.indices[t * 3 + 1], mesh.indices[t * 3]});
    std::vector<uint32_t> map;
    Result<ClusterDag> dag = buildClusterDag(mesh, {}, &map);
    ASSERT_TRUE(dag.ok());
    EXPECT_GT(dag->levels.size(), 2u);
    EXPECT_EQ(map, sourceTriangleClusters(mesh, *dag)) << subdivisions;
    EXPECT_EQ(std::count(map.begin(), map.end(), kNone), 2);
  }
}

TEST(ClusterDag, TinyAndEmptyMeshes) {
  Mesh tiny = makeTerrain(2, 1);
  tiny.indices.resize(10 * 3 > tiny.indices.size() ? tiny.indices.size() : 30);
  Mesh ten = makeTerrain(3, 1);
  ten.indices.resize(30); // 10 triangles
  ClusterDag dag = buildAndVerify(ten);
  EXPECT_EQ(dag.clusters.size(), 1u);
  EXPECT_EQ(dag.roots.size(), 1u);
  buildAndVerify(tiny);

  Mesh degenerateOnly;
  degenerateOnly.positions = {{0, 0, 0}, {1, 0, 0}};
  degenerateOnly.indices = {0, 0, 1};
  Result<ClusterDag> empty = buildClusterDag(degenerateOnly, {});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->clusters.empty());
  EXPECT_TRUE(verifyDag(*empty).ok());
}

TEST(ClusterDag, BadInputIsAnErrorNotACrash) {
  Mesh mesh = makeTerrain(2, 1);
  mesh.indices.push_back(999);
  EXPECT_FALSE(buildClusterDag(mesh, {}).ok());
  mesh.indices.resize(mesh.indices.size() - 1);
  BuildConfig cfg;
  cfg.clusterVertices = 256; // 8-bit local indices
  EXPECT_FALSE(buildClusterDag(mesh, cfg).ok());
  cfg = {};
  cfg.clusterTriangles = 130;
  EXPECT_FALSE(buildClusterDag(mesh, cfg).ok());
}

// The builder's cluster size limit is the renderer's (shaderio/cluster.h): the largest allowed size
// builds clusters the renderer draws, one more step is refused with an error naming the limit.
TEST(ClusterDag, ClusterSizeLimitIsTheRenderers) {
  static_assert(kMaxClusterTriangles == MIRAGE_CLUSTER_MAX_TRIANGLES);
  Mesh mesh = makeBlob(4, 5);
  BuildConfig cfg;
  cfg.clusterTriangles = kMaxClusterTriangles;
  cfg.clusterVertices = 255;
  auto dag = buildClusterDag(mesh, cfg);
  ASSERT_TRUE(dag.ok()) << dag.error().message;
  for (const Cluster& c : dag->clusters) {
    EXPECT_LE(c.triangleCount, uint32_t(MIRAGE_CLUSTER_MAX_TRIANGLES));
    EXPECT_LE(c.vertexCount, uint32_t(MIRAGE_CLUSTER_MAX_VERTICES));
  }
  cfg.clusterTriangles = kMaxClusterTriangles + 4;
  auto refused = buildClusterDag(mesh, cfg);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find(std::to_string(kMaxClusterTriangles)), std::string::npos)
      << refused.error().message;
}

TEST(ClusterDag, RandomSmallMeshesProperty) {
  uint32_t stuck = 0;
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    SCOPED_TRACE(seed);
    BuildConfig cfg;
    cfg.clusterTriangles = 8 + 4 * (seed % 8); // small clusters give several levels on tiny meshes
    cfg.clusterVertices = std::max<uint32_t>(cfg.clusterTriangles, 16);
    cfg.groupClusters = 2 + seed % 7;
    ClusterDag dag = buildAndVerify(makeRandomMesh(seed), 100, cfg);
    for (const LevelStats& l : dag.levels) stuck += l.stuckGroups;
    if (HasFailure()) break;
  }
  // These meshes (holes, fins, tiny clusters) must exercise the stuck-group path the cuts rely on.
  EXPECT_GT(stuck, 0u);
}

TEST(ClusterDag, ThreadCountDoesNotChangeTheResult) {
  Mesh mesh = makeTerrain(60, 4);
  BuildConfig one;
  one.threads = 1;
  Result<ClusterDag> a = buildClusterDag(mesh, one), b = buildClusterDag(mesh, {});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->clusterIndices, b->clusterIndices);
  EXPECT_EQ(a->clusterVertices, b->clusterVertices);
}

} // namespace
} // namespace mirage::lod

namespace mirage::lod {
// The verifiers must catch broken DAGs and cuts, or the tests above prove nothing.
class BrokenDag : public ::testing::Test {
protected:
  void SetUp() override {
    mesh = lodtest::makeBlob(4, 11);
    Result<ClusterDag> r = buildClusterDag(mesh, {});
    ASSERT_TRUE(r.ok());
    dag = std::move(r).value();
    ASSERT_TRUE(verifyDag(dag).ok());
    ASSERT_GE(dag.groups.size(), 3u);
  }
  Mesh mesh;
  ClusterDag dag;
};

namespace {

TEST_F(BrokenDag, MissingClusterIsACrack) {
  std::vector<uint32_t> cut = selectCut(dag, 0.0f);
  cut.erase(cut.begin() + cut.size() / 2);
  Status s = verifyCut(dag, cut, mesh);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("crack"), std::string::npos) << s.error().message;
}

TEST_F(BrokenDag, ClusterWithItsAncestorIsAnOverlap) {
  std::vector<uint32_t> cut = selectCut(dag, 0.0f);
  cut.push_back(dag.groupParents[dag.groups[0].parentOffset]);
  EXPECT_FALSE(verifyCut(dag, cut, mesh).ok());
}

TEST_F(BrokenDag, NonMonotonicErrorIsCaught) {
  Group& g = dag.groups[dag.groups.size() - 1];
  uint32_t child = dag.groupChildren[g.childOffset];
  dag.clusters[child].self.error = g.bounds.error * 2.0f + 1.0f;
  EXPECT_FALSE(verifyDag(dag).ok());
}

TEST_F(BrokenDag, SphereThatDoesNotNestIsCaught) {
  Group& g = dag.groups[0];
  g.bounds.radius *= 0.5f;
  for (uint32_t i = 0; i < g.childCount; ++i) dag.clusters[dag.groupChildren[g.childOffset + i]].parent = g.bounds;
  Status s = verifyDag(dag);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("sphere"), std::string::npos) << s.error().message;
}

TEST_F(BrokenDag, CollapsedParentClusterIsCaught) {
  // Point every vertex of a parent cluster at one new position: its triangles and the border break.
  const Group& g = dag.groups[0];
  const Cluster& p = dag.clusters[dag.groupParents[g.parentOffset]];
  dag.vertexPosition.push_back(dag.vertexPosition[dag.clusterVertices[p.vertexOffset]]);
  dag.positions.push_back(dag.positions[dag.vertexPosition.back()] + glm::vec3(1e-3f));
  dag.vertexPosition.back() = uint32_t(dag.positions.size() - 1);
  for (uint32_t v = 0; v < p.vertexCount; ++v)
    dag.clusterVertices[p.vertexOffset + v] = uint32_t(dag.vertexPosition.size() - 1);
  EXPECT_FALSE(verifyDag(dag).ok());
}

} // namespace
} // namespace mirage::lod
