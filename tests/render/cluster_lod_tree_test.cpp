// The hierarchical selections' trees of a paged asset (src/render/cluster_lod_tree.h,
// docs/render.md "Residency"), on the CPU: built from the page tables alone, every cluster in one
// leaf of each tree, every node above a cluster's leaves holding its parent sphere and error bound
// from the start, and its self and culling spheres once its page arrived (growTrees), as the
// traversal's skip tests need for the cut of any resident set to equal the flat pass's; growing
// a hand-made leaf grows exactly the nodes above it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "cluster_residency.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "render/cluster_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

bool holds(glm::vec4 outer, glm::vec4 inner) {
  return glm::length(glm::vec3(inner) - glm::vec3(outer)) + inner.w <= outer.w;
}

// The nodes from cluster `c`'s leaf in `tree` (0: LOD BVH, 1: DAG tree) up to the tree's root, or
// empty when the leaf does not list the cluster.
std::vector<uint32_t> pathOf(const LodTrees& t, const sio::GpuClusterMesh& gm, uint32_t c, uint32_t tree) {
  std::vector<uint32_t> path;
  uint32_t leaf = t.clusterLeaf[2 * size_t(gm.clusterOffset + c) + tree];
  if (leaf >= t.nodes.size() || !t.nodes[leaf].leaf) return path;
  const sio::GpuLodNode& n = t.nodes[leaf];
  bool listed = false;
  for (uint32_t i = 0; i < n.childCount; ++i) listed = listed || t.leafClusters[n.childOffset + i] == c;
  if (!listed) return path;
  for (uint32_t at = leaf; at != lod::kNone; at = t.parent[at]) path.push_back(at);
  return path;
}

} // namespace

TEST(ClusterLodTree, PagedTreesHoldEveryClusterOnceItsPageArrived) {
  std::string path = (test::tempDir("lodtree") / "blob.mrg").string();
  lod::LodWriteOptions o;
  o.paged = true;
  o.pages.pageBytes = 8 * 1024;
  // Culling spheres above level 0 of 4 times their radius: some stick out of their member
  // groups' spheres, the bounds the tables give.
  lod::LodAsset wide = test::blobAsset();
  for (lod::Cluster& c : wide.dags[0].clusters)
    if (c.level > 0) c.bounds.radius *= 4.0f;
  ASSERT_TRUE(lod::saveLodAsset(path, wide, o).ok());
  auto asset = lod::openPagedLodAsset(path);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  auto tables = pagedSceneTables(*asset);
  ASSERT_TRUE(tables.ok()) << tables.error().message;
  LodTrees& trees = tables->trees;
  const sio::GpuClusterMesh& gm = tables->meshes[0];
  const lod::PageTable& table = asset->meshes[0].table;
  ASSERT_EQ(gm.clusterCount, table.clusterPage.size());
  EXPECT_LE(trees.lodDepth, 6u);
  EXPECT_LE(trees.dagDepth, gm.levelCount + 1) << "owners are of higher levels";
  // Before any page: one leaf per tree for every cluster; the parent spheres and errors held
  // above it; the root pages' self and culling spheres too.
  for (uint32_t c = 0; c < gm.clusterCount; ++c)
    for (uint32_t tree = 0; tree < 2; ++tree) {
      std::vector<uint32_t> up = pathOf(trees, gm, c, tree);
      ASSERT_FALSE(up.empty()) << "cluster " << c << " tree " << tree;
      if (tree == 1) {
        EXPECT_EQ(trees.nodes[up.back()].maxParentError, INFINITY) << "the DAG tree's root holds the roots";
      }
      const sio::GpuCluster& r = tables->clusters[gm.clusterOffset + c];
      for (uint32_t n : up) {
        EXPECT_GE(trees.nodes[n].maxParentError, r.parentError);
        if (!std::isinf(r.parentError)) {
          EXPECT_TRUE(holds(trees.nodes[n].sphere, r.parentSphere));
        }
        if (table.clusterPage[c] < table.rootPageCount) {
          EXPECT_TRUE(holds(trees.nodes[n].sphere, r.selfSphere) && holds(trees.nodes[n].sphere, r.boundsSphere));
        }
      }
    }
  // Every other page arrives: its clusters' spheres are held above their leaves.
  uint32_t outside = 0; // (cluster, tree) spheres the tables' bounds did not hold
  std::vector<uint32_t> grown;
  for (uint32_t p = table.rootPageCount; p < table.pages.size(); ++p) {
    auto data = lod::readPage(*asset->reader, asset->meshes[0], p);
    ASSERT_TRUE(data.ok()) << data.error().message;
    PreparedPage prep = preparePage(*data, table, 0, p, 0, 0);
    for (size_t i = 0; i < prep.ids.size(); ++i)
      for (uint32_t tree = 0; tree < 2; ++tree) {
        uint32_t leaf = trees.clusterLeaf[2 * size_t(prep.ids[i]) + tree];
        outside += !holds(trees.nodes[leaf].sphere, prep.records[i].boundsSphere);
      }
    growTrees(trees, prep, grown);
    for (size_t i = 0; i < prep.ids.size(); ++i)
      for (uint32_t tree = 0; tree < 2; ++tree)
        for (uint32_t n : pathOf(trees, gm, prep.ids[i], tree))
          EXPECT_TRUE(holds(trees.nodes[n].sphere, prep.records[i].selfSphere) &&
                      holds(trees.nodes[n].sphere, prep.records[i].boundsSphere))
              << "page " << p << " cluster " << prep.ids[i] << " tree " << tree;
  }
  EXPECT_GT(outside, 0u) << "no culling sphere stuck out: the growth went untested";
  EXPECT_FALSE(grown.empty());
  // A page arriving again (reloaded after an eviction) changes nothing.
  auto again = lod::readPage(*asset->reader, asset->meshes[0], table.pages.size() - 1);
  ASSERT_TRUE(again.ok());
  std::vector<uint32_t> none;
  growTrees(trees, preparePage(*again, table, 0, uint32_t(table.pages.size() - 1), 0, 0), none);
  EXPECT_TRUE(none.empty());
}

// A hand-made mesh whose culling sphere sticks out of its member group's sphere (which the
// tables give): four level-0 clusters of one group under one root. Before their page the leaves
// hold only the group's sphere; growing by the culling sphere grows the leaf and every node above
// it in both trees to hold it, and growing by it again changes nothing.
TEST(ClusterLodTree, GrowingALeafGrowsEveryNodeAboveIt) {
  std::vector<sio::GpuCluster> clusters(5);
  for (uint32_t c = 0; c < 4; ++c) {
    clusters[c].parentSphere = {0.0f, 0.0f, 0.0f, 2.0f};
    clusters[c].parentError = 1.0f;
  }
  clusters[4].parentError = INFINITY;
  clusters[4].selfSphere = clusters[4].boundsSphere = {0.0f, 0.0f, 0.0f, 2.0f};
  std::vector<uint8_t> known{0, 0, 0, 0, 1};
  std::vector<uint32_t> memberGroup{0, 0, 0, 0, lod::kNone};
  std::vector<sio::GpuClusterLevel> levels{{0, 4, 0.0f, 1.0f}, {4, 1, 1.0f, INFINITY}};
  std::vector<uint32_t> groupLevel{0}, memberOffset{0, 4}, groupMembers{0, 1, 2, 3}, owner{lod::kNone}, roots{4};
  LodTreeMesh mesh{clusters, known, memberGroup, levels, groupLevel, memberOffset, groupMembers, owner, roots};
  sio::GpuClusterMesh gm{};
  gm.clusterCount = 5;
  LodTrees trees;
  trees.growable = true;
  ASSERT_TRUE(appendLodTrees(mesh, gm, trees, "hand-made").ok());
  glm::vec4 sticking{2.5f, 0.0f, 0.0f, 1.0f};
  for (uint32_t tree = 0; tree < 2; ++tree) {
    SCOPED_TRACE(tree == 0 ? "LOD BVH" : "DAG tree");
    std::vector<uint32_t> up = pathOf(trees, gm, 2, tree);
    ASSERT_FALSE(up.empty());
    EXPECT_FALSE(holds(trees.nodes[up.front()].sphere, sticking));
    std::vector<uint32_t> changed;
    growLodLeaf(trees, up.front(), sticking, changed);
    EXPECT_FALSE(changed.empty());
    for (uint32_t n : up) EXPECT_TRUE(holds(trees.nodes[n].sphere, sticking)) << "node " << n;
    for (uint32_t n : changed) EXPECT_NE(std::find(up.begin(), up.end(), n), up.end()) << "only the path grows";
    changed.clear();
    growLodLeaf(trees, up.front(), sticking, changed);
    EXPECT_TRUE(changed.empty());
  }
}
