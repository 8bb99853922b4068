// Cluster-level PVS for the cluster-LOD renderer (lod/cluster_pvs.h, docs/visibility.md "Cluster
// PVS"): the source-triangle map the builder records, the closure rule over the DAG, and the
// renderer culling with it from inside a view cell of a small generated city.
#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/cluster_pvs.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"
#include "test_support.h"

using namespace mirage;
namespace fs = std::filesystem;

namespace {

// gen:city:2 (seed 1, 53 instances) baked once for every test here, and a street cell of it.
struct CityFixture {
  Scene scene;
  lod::LodAsset asset;
  vis::ViewCell cell;
};

const CityFixture& cityFixture() {
  static const CityFixture f = [] {
    CityFixture c;
    c.scene = io::generateScene("city", 1, 2).value();
    c.asset = lod::bakeLodAsset(c.scene, {}).value();
    c.cell.position = {0.0f, 1.7f, -30.0f};
    c.cell.size = {4.0f, 2.0f, 4.0f};
    return c;
  }();
  return f;
}

std::array<uint32_t, 3> weldedTriple(const lod::ClusterDag& dag, uint32_t a, uint32_t b, uint32_t c) {
  std::array<uint32_t, 3> k{dag.vertexPosition[a], dag.vertexPosition[b], dag.vertexPosition[c]};
  std::sort(k.begin(), k.end());
  return k;
}

} // namespace

// Every non-degenerate source triangle maps to a level-0 cluster that holds a triangle over the same
// three welded positions; the map survives save and load.
TEST(ClusterPvs, SourceMapFindsEveryTriangleInItsLevelZeroCluster) {
  const CityFixture& f = cityFixture();
  ASSERT_EQ(f.asset.sourceClusters.size(), f.scene.meshes.size());
  uint64_t mapped = 0, degenerate = 0;
  for (size_t m = 0; m < f.scene.meshes.size(); ++m) {
    const Mesh& mesh = f.scene.meshes[m];
    const lod::ClusterDag& dag = f.asset.dags[m];
    const std::vector<uint32_t>& map = f.asset.sourceClusters[m];
    ASSERT_EQ(map.size(), mesh.triangleCount());
    for (size_t t = 0; t < map.size(); ++t) {
      auto key = weldedTriple(dag, mesh.indices[t * 3], mesh.indices[t * 3 + 1], mesh.indices[t * 3 + 2]);
      if (key[0] == key[1] || key[1] == key[2]) {
        EXPECT_EQ(map[t], lod::kNone);
        ++degenerate;
        continue;
      }
      ASSERT_NE(map[t], lod::kNone) << "mesh " << m << " triangle " << t;
      const lod::Cluster& c = dag.clusters[map[t]];
      ASSERT_EQ(c.level, 0u);
      bool found = false;
      for (uint32_t k = 0; k < c.triangleCount && !found; ++k) {
        const uint8_t* l = &dag.clusterIndices[(size_t(c.triangleOffset) + k) * 3];
        const uint32_t* v = &dag.clusterVertices[c.vertexOffset];
        found = weldedTriple(dag, v[l[0]], v[l[1]], v[l[2]]) == key;
      }
      EXPECT_TRUE(found) << "mesh " << m << " triangle " << t;
      ++mapped;
    }
  }
  EXPECT_GT(mapped, 1000u);
  fs::path path = test::tempDir("cluster_pvs") / "city.mrg";
  ASSERT_TRUE(lod::saveLodAsset(path.string(), f.asset).ok());
  auto loaded = lod::loadLodAsset(path.string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->sourceClusters, f.asset.sourceClusters);
}

// The set is exactly the closure: a level-0 cluster iff one of its source triangles is listed, a
// coarser one iff a child of its generating group is in; instances without one are culled.
TEST(ClusterPvs, IsTheClosureOfTheTrianglePvsOverTheDag) {
  const CityFixture& f = cityFixture();
  std::vector<uint64_t> offsets = vis::triangleOffsets(f.scene);
  std::mt19937 rng(7);
  std::vector<uint32_t> ids;
  for (uint64_t t = 0; t < offsets.back(); ++t)
    if (rng() % 997 == 0) ids.push_back(uint32_t(t));
  auto set = lod::clusterPvs(f.asset.scene, f.asset.dags, f.asset.sourceClusters, ids);
  ASSERT_TRUE(set.ok()) << set.error().message;
  EXPECT_EQ(lod::sourceTriangleCount(f.asset.scene, f.asset.sourceClusters), offsets.back());
  uint64_t visible = 0;
  uint32_t instancesIn = 0;
  for (uint32_t i = 0; i < f.scene.instances.size(); ++i) {
    uint32_t m = f.scene.instances[i].mesh;
    const lod::ClusterDag& dag = f.asset.dags[m];
    std::vector<uint8_t> expect(dag.clusters.size(), 0);
    for (uint32_t id : ids)
      if (id >= offsets[i] && id < offsets[i + 1]) {
        uint32_t c = f.asset.sourceClusters[m][id - offsets[i]];
        if (c != lod::kNone) expect[c] = 1;
      }
    for (size_t c = 0; c < dag.clusters.size(); ++c) {
      uint32_t g = dag.clusters[c].generatingGroup;
      if (g == lod::kNone) continue;
      const lod::Group& group = dag.groups[g];
      for (uint32_t k = 0; k < group.childCount; ++k) expect[c] |= expect[dag.groupChildren[group.childOffset + k]];
    }
    bool any = std::find(expect.begin(), expect.end(), 1) != expect.end();
    EXPECT_EQ(set->instanceBitOffset[i] != lod::kPvsInstanceCulled, any) << "instance " << i;
    instancesIn += any;
    for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
      ASSERT_EQ(set->visible(i, c), bool(expect[c])) << "instance " << i << " cluster " << c;
      visible += expect[c];
    }
    // Each visible instance keeps at least one root: any LOD cut, however coarse, has a visible cluster.
    if (any) {
      bool root = false;
      for (uint32_t r : dag.roots) root |= set->visible(i, r);
      EXPECT_TRUE(root) << "instance " << i;
    }
  }
  EXPECT_EQ(set->visibleClusters, visible);
  EXPECT_EQ(set->visibleInstances, instancesIn);
  EXPECT_GT(instancesIn, 0u);
  EXPECT_LT(instancesIn, f.scene.instances.size());
  std::vector<uint32_t> outside{uint32_t(offsets.back())};
  EXPECT_FALSE(lod::clusterPvs(f.asset.scene, f.asset.dags, f.asset.sourceClusters, outside).ok());
}

class ClusterPvsRender : public test::GpuTest {};

// From inside a view cell: the PVS-culled cluster-LOD image equals the unculled one (but for the
// PVS's own pixel error), fewer clusters and triangles are drawn, and every cluster that owns a
// pixel in the unculled frame is in the cluster PVS. Flat and hierarchical selection alike.
TEST_F(ClusterPvsRender, CulledImageMatchesAndOwnedClustersAreInThePvs) {
  const CityFixture& f = cityFixture();
  auto backend = vis::createEmbreeBackend(f.scene);
  ASSERT_TRUE(backend.ok()) << backend.error().message;
  vis::GvsConfig config;
  config.randomRays = 200000;
  config.rayBudget = 2000000;
  vis::CellPvs pvs = vis::computeCellPvs(**backend, f.scene, f.cell, config);
  auto set = lod::clusterPvs(f.asset.scene, f.asset.dags, f.asset.sourceClusters, pvs.triangles);
  ASSERT_TRUE(set.ok()) << set.error().message;
  auto renderer = render::ClusterRenderer::create(context(), f.asset);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  render::ClusterRenderer& r = **renderer;
  uint64_t instanced = 0;
  for (const Instance& inst : f.scene.instances) instanced += f.asset.dags[inst.mesh].clusters.size();
  EXPECT_LT(set->visibleClusters, instanced);
  EXPECT_LT(set->visibleInstances, f.scene.instances.size());
  uint64_t trianglesFull = 0, trianglesCulled = 0;
  uint32_t instancesPvsCulled = 0, clustersPvsCulled = 0;

  for (render::SelectionMode mode :
       {render::SelectionMode::Flat, render::SelectionMode::Hierarchy, render::SelectionMode::Dag})
    for (int v = 0; v < 4; ++v) {
      SCOPED_TRACE(testing::Message() << render::toString(mode) << " view " << v);
      render::ClusterRenderSettings cs;
      cs.base.width = 160;
      cs.base.height = 120;
      float a = float(v) * 1.5707963f;
      cs.base.camera.eye = f.cell.position + glm::vec3(0.7f, -0.3f, 0.4f); // inside, off-centre
      cs.base.camera.target = cs.base.camera.eye + glm::vec3(std::cos(a), 0.05f, std::sin(a));
      cs.base.camera.fovYDegrees = 70.0f;
      cs.selection = mode;
      cs.occlusionCulling = true; // its history tells which clusters own pixels
      cs.readOwnedClusters = true;
      ASSERT_TRUE(r.setPvs(nullptr).ok());
      // Two frames each: the second has the history of the first (same clusters, pass 1 non-empty).
      auto full = r.render(cs);
      full = r.render(cs);
      ASSERT_TRUE(full.ok()) << full.error().message;
      ASSERT_TRUE(r.setPvs(&*set).ok());
      auto culled = r.render(cs);
      culled = r.render(cs);
      ASSERT_TRUE(culled.ok()) << culled.error().message;
      EXPECT_FALSE(full->stats.pvs);
      EXPECT_TRUE(culled->stats.pvs);

      // (a) the same image within the PVS's pixel error (docs/visibility.md: GVS++ leaves ~1 wrong
      // pixel per 500^2 view; here at most 0.5% of the pixels may differ).
      const ImageRGBA8 &x = full->image.srgb, &y = culled->image.srgb;
      uint32_t differing = 0;
      for (uint32_t py = 0; py < x.height; ++py)
        for (uint32_t px = 0; px < x.width; ++px)
          differing += !std::equal(x.at(px, py), x.at(px, py) + 3, y.at(px, py));
      EXPECT_LE(differing, x.width * x.height / 200) << "PSNR " << psnr(x, y);
      // (b) the PVS never adds work; over the views it culls instances before selection and
      // clusters and triangles after (below).
      EXPECT_LE(culled->stats.instancesVisible, full->stats.instancesVisible);
      EXPECT_LE(culled->stats.clustersDrawn, full->stats.clustersDrawn);
      EXPECT_LE(culled->stats.trianglesRasterized, full->stats.trianglesRasterized);
      trianglesFull += full->stats.trianglesRasterized;
      trianglesCulled += culled->stats.trianglesRasterized;
      instancesPvsCulled += culled->stats.instancesPvsCulled;
      clustersPvsCulled += culled->stats.clustersPvsCulled;
      // (c) conservative: every cluster owning a pixel of the unculled frame is in the cluster PVS.
      ASSERT_FALSE(full->ownedClusters.empty());
      uint32_t missing = 0;
      for (auto [instance, cluster] : full->ownedClusters) missing += !set->visible(instance, cluster);
      EXPECT_EQ(missing, 0u) << "of " << full->ownedClusters.size() << " owning clusters";
      for (auto [instance, cluster] : culled->ownedClusters) EXPECT_TRUE(set->visible(instance, cluster));
    }
  EXPECT_GT(instancesPvsCulled, 0u);
  EXPECT_GT(clustersPvsCulled, 0u);
  EXPECT_LT(trianglesCulled, trianglesFull);
  std::printf("cluster PVS: %u of %zu instances, %llu of %llu (instance, cluster) pairs, %llu bytes (triangle PVS: "
              "%zu triangles); 8 frames: triangles %llu with vs %llu without, %u instances + %u clusters culled\n",
              set->visibleInstances, f.scene.instances.size(), (unsigned long long)set->visibleClusters,
              (unsigned long long)instanced, (unsigned long long)set->bytes(), pvs.triangles.size(),
              (unsigned long long)trianglesCulled, (unsigned long long)trianglesFull, instancesPvsCulled,
              clustersPvsCulled);
}

// mirage render / bench render on a .mrg with --pvs: a PVS of another scene is one line on stderr,
// exit 2 and no image; the right one culls from inside its cell and says which cell it used.
TEST(ClusterPvsCli, RendersWithThePvsAndRejectsAnotherScenes) {
  ASSERT_TRUE(fs::exists(test::mirageBinary())) << test::mirageBinary();
  const CityFixture& f = cityFixture();
  fs::path dir = test::tempDir("cluster_pvs_cli");
  fs::path asset = dir / "city.mrg", good = dir / "good_pvs.mrg", other = dir / "other_pvs.mrg";
  ASSERT_TRUE(lod::saveLodAsset(asset.string(), f.asset).ok());
  vis::PvsData pvs;
  pvs.cells = {f.cell};
  pvs.sceneTriangles = f.scene.instancedTriangleCount();
  for (uint32_t t = 0; t < pvs.sceneTriangles; t += 3) pvs.triangles.resize(1), pvs.triangles[0].push_back(t);
  ASSERT_TRUE(vis::savePvs(good.string(), pvs, "gen:city:2").ok());
  Scene otherScene = io::generateScene("city", 2, 1).value();
  ASSERT_NE(otherScene.instancedTriangleCount(), pvs.sceneTriangles);
  pvs.sceneTriangles = otherScene.instancedTriangleCount();
  pvs.triangles[0] = {0, 1, 2};
  ASSERT_TRUE(vis::savePvs(other.string(), pvs, "gen:city:1:2").ok());

  auto run = [&](const std::string& args, std::string& out, std::string& err) {
    std::string cmd =
        test::mirageBinary() + " " + args + " > " + (dir / "out.txt").string() + " 2> " + (dir / "err.txt").string();
    int status = std::system(cmd.c_str());
    std::ifstream o(dir / "out.txt"), e(dir / "err.txt");
    out.assign(std::istreambuf_iterator<char>(o), {});
    err.assign(std::istreambuf_iterator<char>(e), {});
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  std::string camera = " --camera eye=0,1.7,-30,target=1,1.7,-30 --size 64x48";
  fs::path png = dir / "out.png";
  std::string out, err;
  EXPECT_EQ(run("render " + asset.string() + " --pvs " + other.string() + camera + " -o " + png.string(), out, err), 2);
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find("other_pvs.mrg"), std::string::npos) << err;
  EXPECT_NE(err.find("another scene"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(png));
  EXPECT_EQ(run("bench render " + asset.string() + " --pvs " + other.string() + " --frames 2 --size 64x48", out, err),
            2);
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;

  EXPECT_EQ(
      run("render " + asset.string() + " --pvs " + good.string() + camera + " --stats -o " + png.string(), out, err), 0)
      << err;
  EXPECT_NE(out.find("PVS: cell 0 of 1"), std::string::npos) << out;
  EXPECT_NE(out.find("cell PVS:"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(png));
  EXPECT_EQ(run("render " + asset.string() + " --pvs " + good.string() +
                    " --camera eye=500,500,500,target=0,0,0 --size 64x48 -o " + png.string(),
                out, err),
            0)
      << err;
  EXPECT_NE(out.find("in none of the 1 view cells: no PVS culling"), std::string::npos) << out;
}
