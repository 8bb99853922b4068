// GPU residency of a paged asset read on demand (docs/render.md, "Residency"), on lavapipe with
// validation: with room for the view's pages the converged image is the unbudgeted one, a tiny
// budget gives a complete, crack-free coarser image, no frame's resident bytes exceed the budget,
// a moving camera evicts and reloads pages while each stop converges to the unbudgeted image,
// prefetch brings a camera cut to full quality in fewer frames, to the same image, and is computed
// again on cuts only. The hierarchical selections (LOD BVH, DAG tree) draw the flat pass's
// resident cut and ask for the same pages, and auto picks the hierarchy for many instances.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/shaderio/cluster.h"
#include "render/cluster_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kResidencySize = 160;

} // namespace

// The fixture has the name of render::ClusterResidency (src/render/cluster_residency.h, which
// another file of this test binary includes, beside `using namespace mirage::render`): the tests
// live in a namespace of their own, where TEST_F finds the fixture first.
namespace cluster_residency_test {

class ClusterResidency : public test::GpuTest {};

namespace {

// A scene written paged with small pages (many of them), its unbudgeted reference (the DAG
// reassembled from the same pages) and the on-demand asset.
struct PagedBlob {
  std::string path;
  lod::LodAsset whole;
  uint64_t geometryBytes = 0; // every page's vertices, vertex ids and indices: the whole asset
};
PagedBlob writePaged(const std::string& name, const lod::LodAsset& asset) {
  PagedBlob out;
  out.path = (test::tempDir("residency" + name) / (name + ".mrg")).string();
  lod::LodWriteOptions o;
  o.paged = true;
  o.pages.pageBytes = 8 * 1024;
  if (!lod::saveLodAsset(out.path, asset, o).ok()) std::abort();
  auto whole = lod::loadLodAsset(out.path);
  if (!whole) std::abort();
  out.whole = std::move(*whole);
  auto paged = lod::openPagedLodAsset(out.path);
  if (!paged) std::abort();
  for (const lod::PagedMesh& m : paged->meshes)
    for (uint32_t p = 0; p < m.table.pages.size(); ++p)
      out.geometryBytes += m.table.pages[p].vertexCount * 32ull + m.rest.pageClusterVertices[p] * 4ull +
                           m.table.pages[p].triangleCount * 3ull;
  return out;
}

// The geometric-error blob.
const PagedBlob& pagedBlob() {
  static PagedBlob b = writePaged("blob", test::blobAsset());
  return b;
}

// A blob of small groups (4 clusters: groups' spheres the traversal can frustum-cull) whose
// clusters above level 0 have culling spheres of 4 times their radius, sticking out of their
// member groups' spheres (the page tables' bounds): the hierarchical selections' trees must grow
// to hold them as their pages arrive, or they cull nodes of clusters the flat pass draws.
const PagedBlob& pagedWideBlob() {
  static PagedBlob b = [] {
    io::BlobOptions o;
    o.subdivisions = 5;
    lod::BuildConfig config;
    config.normalWeight = 0.0f;
    config.groupClusters = 4;
    auto asset = lod::bakeLodAsset(io::generateBlob(o), config);
    if (!asset) std::abort();
    for (lod::Cluster& c : asset->dags[0].clusters)
      if (c.level > 0) c.bounds.radius *= 4.0f;
    return writePaged("wide", *asset);
  }();
  return b;
}

// Two different blobs (noise seeds 1 and 2, 20480 triangles each) `kPairGap` radii apart along x:
// a close view of one sees nothing of the other, so two stops need disjoint page sets.
constexpr float kPairGap = 8.0f;
const PagedBlob& pagedPair() {
  static PagedBlob b = [] {
    Scene scene;
    for (uint32_t seed : {1u, 2u}) {
      io::BlobOptions o;
      o.subdivisions = 5;
      o.seed = seed;
      Scene blob = io::generateBlob(o);
      if (scene.materials.empty()) scene.materials = blob.materials;
      Mesh m = std::move(blob.meshes[0]);
      m.name = "blob" + std::to_string(seed);
      m.material = 0;
      scene.meshes.push_back(std::move(m));
      Instance inst;
      inst.mesh = uint32_t(scene.meshes.size() - 1);
      inst.transform = glm::translate(glm::mat4(1.0f), glm::vec3((seed == 1 ? -0.5f : 0.5f) * kPairGap, 0, 0));
      scene.instances.push_back(inst);
    }
    scene.source = "generated:pair";
    lod::BuildConfig config;
    config.normalWeight = 0.0f; // the geometric error: close views need fine pages, far ones coarse
    auto baked = lod::bakeLodAsset(scene, config);
    if (!baked) std::abort();
    return writePaged("pair", *baked);
  }();
  return b;
}

ClusterRenderSettings viewSettings(const Camera& cam) {
  ClusterRenderSettings s;
  s.base.width = s.base.height = kResidencySize;
  s.base.camera = cam;
  s.base.background = {0, 0, 0, 1};
  s.raster = RasterBackend::Compute;
  return s;
}

Camera overview() { return autoCamera(pagedBlob().whole.scene.worldBounds(), 1.0f); }

// A view of the box `b` from direction `dir` at `distance` radii, aimed `aim` radii from its
// centre towards the eye, with a vertical field of view of `fov` degrees.
Camera closeViewOf(const Bounds& b, glm::vec3 dir, float distance, float aim, float fov) {
  Camera c;
  c.target = b.center() + glm::normalize(dir) * (aim * b.radius());
  c.eye = b.center() + glm::normalize(dir) * (distance * b.radius());
  c.fovYDegrees = fov;
  if (std::abs(glm::normalize(dir).y) > 0.9f) c.up = {0, 0, 1};
  return c;
}
Camera closeView(glm::vec3 dir, float distance, float aim, float fov) {
  return closeViewOf(pagedBlob().whole.scene.worldBounds(), dir, distance, aim, fov);
}

struct Opened {
  lod::PagedLodAsset asset;
  std::unique_ptr<ClusterRenderer> renderer;
};
Opened openBudgeted(gpu::Context& ctx, uint64_t budget, const PagedBlob& blob = pagedBlob(), bool prefetch = true,
                    ClusterResidencySettings::Uploads uploads = ClusterResidencySettings::Uploads::Auto) {
  Opened o;
  auto paged = lod::openPagedLodAsset(blob.path);
  EXPECT_TRUE(paged.ok()) << (paged.ok() ? "" : paged.error().message);
  o.asset = std::move(*paged);
  ClusterResidencySettings rs;
  rs.budgetBytes = budget;
  rs.prefetch = prefetch;
  rs.uploads = uploads;
  auto r = ClusterRenderer::create(ctx, o.asset, rs);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (r.ok()) o.renderer = std::move(*r);
  return o;
}

ImageRGBA8 unbudgeted(gpu::Context& ctx, const ClusterRenderSettings& s, const PagedBlob& blob = pagedBlob()) {
  return test::renderCluster(ctx, blob.whole, s).image.srgb;
}

ClusterRenderer::Converged converge(ClusterRenderer& r, const ClusterRenderSettings& s, uint64_t budget) {
  auto c = r.renderConverged(s);
  EXPECT_TRUE(c.ok()) << (c.ok() ? "" : c.error().message);
  EXPECT_TRUE(c->converged);
  for (const ResidencyStats& f : c->frames) {
    EXPECT_LE(f.residentBytes, budget) << "a frame exceeded the budget";
    EXPECT_LE(f.geometryBytes + f.recordBytes, f.residentBytes) << "the records live in the resident units";
  }
  return std::move(*c);
}

void expectSameImage(const ImageRGBA8& a, const ImageRGBA8& b, const std::string& name) {
  double db = psnr(a, b);
  EXPECT_GE(db, 60.0) << name;
  test::writeOnFailure(a, name + "_budget.png");
  test::writeOnFailure(b, name + "_full.png");
}

// What the view needs, from a renderer with room for everything.
uint64_t viewBytes(gpu::Context& ctx, const ClusterRenderSettings& s, const PagedBlob& blob = pagedBlob()) {
  Opened o = openBudgeted(ctx, 64ull << 20, blob);
  return converge(*o.renderer, s, 64ull << 20).output.stats.residency.residentBytes;
}

} // namespace

TEST_F(ClusterResidency, ConvergedImageEqualsUnbudgeted) {
  ClusterRenderSettings s = viewSettings(closeView({0.3f, 0.2f, 1.0f}, 1.6f, 0.8f, 60.0f));
  uint64_t need = viewBytes(context(), s);
  uint64_t budget = need + 24 * 1024;
  ASSERT_LT(budget, pagedBlob().geometryBytes) << "the budget must be below the asset";
  Opened o = openBudgeted(context(), budget);
  auto c = converge(*o.renderer, s, budget);
  EXPECT_LT(c.output.stats.residency.residentPages, c.output.stats.residency.pages);
  EXPECT_GT(c.output.stats.residency.bytesRead, 0u);
  expectSameImage(c.output.image.srgb, unbudgeted(context(), s), "residency_equal");
}

// The cluster records live in the pool with their pages, within the budget: what stays on the GPU
// per cluster outside it (the cluster-slot table and the trees' leaf lists, from the buffers as
// allocated) is a few bytes, where the record, cone and pages took 124 B; the trees' nodes are per
// group.
TEST_F(ClusterResidency, RecordsLiveInTheBudgetAndLittleStaysPerCluster) {
  ClusterRenderSettings s = viewSettings(closeView({0.3f, 0.2f, 1.0f}, 1.6f, 0.8f, 60.0f));
  s.selection = SelectionMode::Hierarchy; // the trees are allocated either way; drawn from here
  uint64_t budget = 8 * 24 * 1024;
  ASSERT_LT(budget, pagedBlob().geometryBytes) << "the budget must be below the asset";
  Opened o = openBudgeted(context(), budget);
  auto c = converge(*o.renderer, s, budget); // every frame: geometry + records <= resident <= budget
  const ResidencyStats& st = c.output.stats.residency;
  ASSERT_GT(st.clusters, 0u);
  EXPECT_EQ(st.clusters, o.renderer->clusterCount());
  EXPECT_GE(st.clusterTableBytes, 12 * st.clusters) << "the slot table (4 B) and two leaves (8 B) per cluster";
  EXPECT_LE(st.clusterTableBytes, 16 * st.clusters) << "per-cluster GPU tables outside the budget";
  EXPECT_GT(st.treeNodeBytes, 0u);
  EXPECT_LE(st.treeNodeBytes, sizeof(shaderio::GpuLodNode) * st.clusters / 4) << "tree nodes: per group of clusters";
  // The drawn pages' records are resident: at least the root pages' clusters' worth.
  EXPECT_GT(st.recordBytes, 0u);
  EXPECT_EQ(st.recordBytes % sizeof(shaderio::GpuCluster), 0u);
  EXPECT_LT(st.recordBytes, st.clusters * sizeof(shaderio::GpuCluster)) << "not every record is resident";
}

// Root pages and a few units: coarser, but every pixel the full image covers (within a
// silhouette's width) is covered, and no back face shows through a crack, with every selection
// (the traversals' leaves draw resident ancestors where the cut's pages are missing).
void expectTinyBudgetCompleteAndCrackFree(gpu::Context& ctx, SelectionMode selection) {
  SCOPED_TRACE(toString(selection));
  ClusterRenderSettings s = viewSettings(overview());
  s.selection = selection;
  s.flagBackFaces = true;
  s.base.background = {0, 1, 0, 1};
  uint64_t budget = 4 * 24 * 1024;
  Opened o = openBudgeted(ctx, budget);
  auto c = converge(*o.renderer, s, budget);
  EXPECT_EQ(c.output.stats.selection, selection);
  EXPECT_LT(c.output.stats.residency.residentPages, c.output.stats.residency.pages / 2);
  const ImageRGBA8& tiny = c.output.image.srgb;
  ImageRGBA8 full = unbudgeted(ctx, s);
  auto covered = [](const ImageRGBA8& img, uint32_t x, uint32_t y) {
    const uint8_t* p = img.at(x, y);
    return !(p[0] == 0 && p[1] == 255 && p[2] == 0);
  };
  size_t a = 0, differ = 0, interiorFlagged = 0;
  for (uint32_t y = 1; y + 1 < kResidencySize; ++y)
    for (uint32_t x = 1; x + 1 < kResidencySize; ++x) {
      a += covered(full, x, y);
      differ += covered(full, x, y) != covered(tiny, x, y);
      const uint8_t* p = tiny.at(x, y);
      bool flagged = p[0] == 255 && p[1] == 0 && p[2] == 255, nearBackground = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) nearBackground |= !covered(tiny, uint32_t(int(x) + dx), uint32_t(int(y) + dy));
      interiorFlagged += flagged && !nearBackground;
    }
  EXPECT_GT(a, 1000u);
  EXPECT_LT(double(differ), 0.1 * double(a)) << "coverage against the unbudgeted image";
  EXPECT_EQ(interiorFlagged, 0u) << "a crack shows a back face";
  test::writeOnFailure(tiny, std::string("residency_tiny_") + toString(selection) + ".png");
}

TEST_F(ClusterResidency, TinyBudgetIsCompleteAndCrackFree) {
  for (SelectionMode selection : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag})
    expectTinyBudgetCompleteAndCrackFree(context(), selection);
}

namespace {

// Close views of the pair's first blob, its second, then its first again.
std::vector<Camera> pairStops() {
  const Scene& scene = pagedPair().whole.scene;
  std::vector<Camera> stops;
  for (uint32_t i : {0u, 1u, 0u}) {
    const Instance& inst = scene.instances[i];
    Bounds b = scene.meshes[inst.mesh].bounds;
    glm::vec3 shift(inst.transform[3]);
    stops.push_back(closeViewOf(Bounds{b.min + shift, b.max + shift}, {0.3f, 0.2f, 1.0f}, 1.6f, 0.8f, 60.0f));
  }
  return stops;
}

} // namespace

// Close views of two blobs far apart with room for one view's pages at a time: moving from one to
// the other evicts, coming back reloads, and every stop converges to the unbudgeted image.
void expectMovingCameraEvictsAndReloads(gpu::Context& ctx, SelectionMode selection) {
  SCOPED_TRACE(toString(selection));
  const PagedBlob& pair = pagedPair();
  std::vector<Camera> stops = pairStops();
  // A fine threshold: each stop needs its blob's finest pages, well beyond the root pages.
  auto settings = [&](size_t i) {
    ClusterRenderSettings s = viewSettings(stops[i]);
    s.tauPixels = 0.25f;
    s.selection = selection;
    return s;
  };
  uint64_t viewA = viewBytes(ctx, settings(0), pair);
  uint64_t viewB = viewBytes(ctx, settings(1), pair);
  // Headroom for the reservations of pages not read yet (their table bound, above their exact size).
  uint64_t budget = std::max(viewA, viewB) + 4 * 24 * 1024;
  uint64_t both = 0; // both views' pages at once
  {
    Opened all = openBudgeted(ctx, 64ull << 20, pair);
    for (size_t i = 0; i < 2; ++i)
      both = converge(*all.renderer, settings(i), 64ull << 20).output.stats.residency.residentBytes;
  }
  ASSERT_GT(both, budget) << "the budget must not hold both views";
  Opened o = openBudgeted(ctx, budget, pair);
  uint32_t evicted = 0, loadedBack = 0;
  for (size_t i = 0; i < stops.size(); ++i) {
    ClusterRenderSettings s = settings(i);
    auto c = converge(*o.renderer, s, budget);
    EXPECT_EQ(c.output.stats.selection, selection);
    for (const ResidencyStats& f : c.frames) {
      evicted += i > 0 ? f.evicted : 0;
      loadedBack += i == 2 ? f.loaded : 0;
    }
    expectSameImage(c.output.image.srgb, unbudgeted(ctx, s, pair),
                    fmt::format("residency_{}_stop{}", toString(selection), i));
  }
  EXPECT_GT(evicted, 0u) << "the second view needs pages the first one's evicted";
  EXPECT_GT(loadedBack, 0u) << "coming back reloads evicted pages";
}

TEST_F(ClusterResidency, MovingCameraEvictsAndReloads) {
  expectMovingCameraEvictsAndReloads(context(), SelectionMode::Flat);
}

// The same with the LOD BVH: its bounds grown by the pages that arrived hold them after their
// eviction and reload too.
TEST_F(ClusterResidency, MovingCameraEvictsAndReloadsWithTheHierarchy) {
  expectMovingCameraEvictsAndReloads(context(), SelectionMode::Hierarchy);
}

// Pages through the transfer queue (on lavapipe, which has none, its submissions go to the one
// queue, apart from the frames): each page reaches the pool a frame after its batch went out, and
// every stop of the moving camera converges to the image the in-frame uploads give, bit for bit,
// within the budget, with pages evicted and loaded back on the way.
TEST_F(ClusterResidency, TransferUploadsConvergeToTheFrameUploadsImages) {
  using Uploads = ClusterResidencySettings::Uploads;
  const PagedBlob& pair = pagedPair();
  std::vector<ClusterRenderSettings> stops;
  for (const Camera& c : pairStops()) {
    stops.push_back(viewSettings(c));
    stops.back().tauPixels = 0.25f;
  }
  uint64_t budget =
      std::max(viewBytes(context(), stops[0], pair), viewBytes(context(), stops[1], pair)) + 4 * 24 * 1024;
  Opened frame = openBudgeted(context(), budget, pair, true, Uploads::Frame);
  Opened transfer = openBudgeted(context(), budget, pair, true, Uploads::Transfer);
  uint32_t inTransit = 0, evicted = 0;
  for (size_t i = 0; i < stops.size(); ++i) {
    auto a = converge(*frame.renderer, stops[i], budget);
    auto b = converge(*transfer.renderer, stops[i], budget);
    for (const ResidencyStats& f : b.frames) inTransit += f.inTransit, evicted += f.evicted;
    for (const ResidencyStats& f : a.frames) EXPECT_EQ(f.inTransit, 0u);
    EXPECT_TRUE(b.output.image.srgb.pixels == a.output.image.srgb.pixels) << "stop " << i;
    test::writeOnFailure(b.output.image.srgb, "residency_transfer" + std::to_string(i) + ".png");
  }
  EXPECT_GT(inTransit, 0u) << "no page went through the transfer queue";
  EXPECT_GT(evicted, 0u);
}

// A camera cut from the overview to a close view at a fine threshold: the feedback asks for one
// level per frame round trip, prefetch for every level at once, so the cut converges in fewer
// frames (renderConverged's count, not time), to the same image, the unbudgeted one.
TEST_F(ClusterResidency, PrefetchConvergesACutInFewerFrames) {
  ClusterRenderSettings from = viewSettings(overview());
  ClusterRenderSettings to = viewSettings(closeView({0.3f, 0.2f, 1.0f}, 1.6f, 0.8f, 60.0f));
  to.tauPixels = 0.25f;
  uint64_t budget = 64ull << 20;
  uint32_t frames[2] = {0, 0};
  ImageRGBA8 images[2];
  for (bool prefetch : {false, true}) {
    Opened o = openBudgeted(context(), budget, pagedBlob(), prefetch);
    converge(*o.renderer, from, budget);
    auto c = converge(*o.renderer, to, budget);
    frames[prefetch] = c.framesToConverge;
    images[prefetch] = c.output.image.srgb;
  }
  EXPECT_LT(frames[1], frames[0]);
  EXPECT_GE(frames[0], 3u) << "the cut needs several levels";
  expectSameImage(images[1], images[0], "residency_prefetch");
  expectSameImage(images[1], unbudgeted(context(), to), "residency_prefetch_full");
}

// The prefetch is computed again on a camera cut only (render::isCameraCut from the view it was
// last computed for, or the settings' cameraCut) or for a new tau: not for steps of a moving camera
// that stay within the cut's bounds together, and a view reached by such steps still converges to
// the unbudgeted image (the feedback refines what the older prefetch did not ask for).
TEST_F(ClusterResidency, PrefetchIsComputedAgainOnCutsOnly) {
  uint64_t budget = 64ull << 20;
  Opened o = openBudgeted(context(), budget);
  const Bounds& bounds = pagedBlob().whole.scene.worldBounds();
  float diagonal = glm::length(bounds.extent());
  Camera a = closeView({0.3f, 0.2f, 1.0f}, 1.6f, 0.8f, 60.0f);
  auto stepped = [&](const Camera& c, float fraction, float degrees) {
    Camera s = c;
    glm::vec3 shift = glm::normalize(glm::cross(c.target - c.eye, c.up)) * (fraction * diagonal);
    glm::vec3 ahead(glm::rotate(glm::mat4(1.0f), glm::radians(degrees), c.up) * glm::vec4(c.target - c.eye, 0.0f));
    s.eye += shift;
    s.target = s.eye + ahead;
    return s;
  };
  auto prefetched = [&](const Camera& cam, bool cut = false, float tau = 1.0f) {
    ClusterRenderSettings s = viewSettings(cam);
    s.cameraCut = cut;
    s.tauPixels = tau;
    auto out = o.renderer->render(s);
    EXPECT_TRUE(out.ok()) << (out.ok() ? "" : out.error().message);
    return out.ok() && out->stats.residency.prefetched;
  };
  EXPECT_FALSE(prefetched(a)) << "the first frame has no feedback to step on";
  EXPECT_TRUE(prefetched(a)) << "the first view's prefetch";
  EXPECT_FALSE(prefetched(a));
  Camera c = a;
  for (int i = 0; i < 3; ++i) { // 1.5 % of the diagonal and 6 degrees from the prefetch's view
    c = stepped(c, 0.005f, 2.0f);
    EXPECT_FALSE(prefetched(c)) << "step " << i;
  }
  c = stepped(c, 0.01f, 0.0f); // 2.5 %: far enough from where the prefetch was computed
  EXPECT_TRUE(prefetched(c));
  EXPECT_FALSE(prefetched(c));
  EXPECT_TRUE(prefetched(c, /*cut=*/true)) << "the caller's cut";
  EXPECT_FALSE(prefetched(c));
  EXPECT_TRUE(prefetched(c, false, 0.5f)) << "a new tau";
  EXPECT_TRUE(prefetched(overview(), false, 0.5f)) << "a jump";

  // Converged at a, then steps away (no cut): the stepped view's image is the unbudgeted one.
  converge(*o.renderer, viewSettings(a), budget);
  ClusterRenderSettings near = viewSettings(stepped(a, 0.015f, 8.0f));
  auto done = converge(*o.renderer, near, budget);
  for (const ResidencyStats& f : done.frames) EXPECT_FALSE(f.prefetched) << "a step is no cut";
  expectSameImage(done.output.image.srgb, unbudgeted(context(), near), "residency_steps");
}

namespace {

// The (instance, cluster) pairs owning a pixel of the visibility buffer read back.
std::set<std::pair<uint32_t, uint32_t>> visibleClusters(const ClusterRenderOutput& out) {
  std::set<std::pair<uint32_t, uint32_t>> set;
  for (const VisibilitySample& v : out.visibility)
    if (v.instance != UINT32_MAX) set.insert({v.instance, v.cluster});
  return set;
}

// Frame `b` selected and drew what frame `a` did: the counts, the clusters owning pixels and the
// image (identical but for ties between equal depths).
void expectSameCut(const ClusterRenderOutput& a, const ClusterRenderOutput& b, const std::string& name) {
  EXPECT_EQ(a.stats.clustersSelected, b.stats.clustersSelected);
  EXPECT_EQ(a.stats.clustersFrustumCulled, b.stats.clustersFrustumCulled);
  EXPECT_EQ(a.stats.clustersBackfaceCulled, b.stats.clustersBackfaceCulled);
  EXPECT_EQ(a.stats.clustersDrawn, b.stats.clustersDrawn);
  EXPECT_EQ(a.stats.trianglesRasterized, b.stats.trianglesRasterized);
  EXPECT_EQ(b.stats.clustersOverflow, 0u);
  std::set<std::pair<uint32_t, uint32_t>> va = visibleClusters(a), vb = visibleClusters(b);
  EXPECT_GT(va.size(), 0u);
  EXPECT_TRUE(va == vb) << va.size() << " clusters own pixels against " << vb.size();
  expectSameImage(b.image.srgb, a.image.srgb, name);
}

} // namespace

// Under a budget below the asset, the LOD BVH and the DAG tree converge to the flat selection's
// cut (the same clusters selected, frustum- and cone-culled and owning pixels) and image, which is
// the unbudgeted one, within the budget in every frame, from a close view partly out of the
// frustum. Their leaves ask for the same pages: the first frame (the root pages alone drawn,
// prefetch off, so every request is the selection's) asks for as many missing pages, and the next
// frame's step loads as many.
TEST_F(ClusterResidency, HierarchyAndDagConvergeToTheFlatCut) {
  gpu::Context& ctx = context();
  const PagedBlob& blob = pagedBlob();
  ClusterRenderSettings s = viewSettings(closeView({0.3f, 0.2f, 1.0f}, 1.4f, 0.9f, 30.0f));
  s.readVisibility = true;
  uint64_t need = viewBytes(ctx, s, blob);
  uint64_t budget = need + 24 * 1024;
  ASSERT_LT(budget, blob.geometryBytes) << "the budget must be below the asset";
  ClusterRenderOutput flat, full = test::renderCluster(ctx, blob.whole, s);
  uint32_t flatRequested = 0, flatLoaded = 0;
  for (SelectionMode selection : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag}) {
    SCOPED_TRACE(toString(selection));
    s.selection = selection;
    Opened o = openBudgeted(ctx, budget, blob);
    auto c = converge(*o.renderer, s, budget);
    EXPECT_EQ(c.output.stats.selection, selection);
    EXPECT_LT(c.output.stats.residency.residentPages, c.output.stats.residency.pages);
    expectSameImage(c.output.image.srgb, full.image.srgb, fmt::format("residency_{}_full", toString(selection)));
    Opened first = openBudgeted(ctx, budget, blob, /*prefetch=*/false);
    auto f0 = first.renderer->render(s);
    auto f1 = first.renderer->render(s);
    ASSERT_TRUE(f0.ok() && f1.ok());
    if (selection == SelectionMode::Flat) {
      flat = std::move(c.output);
      flatRequested = f0->stats.residency.requested;
      flatLoaded = f1->stats.residency.loaded;
      EXPECT_GT(flatRequested, 0u);
      EXPECT_GT(flatLoaded, 0u);
      continue;
    }
    expectSameCut(flat, c.output, fmt::format("residency_{}_flat", toString(selection)));
    EXPECT_GT(c.output.stats.nodesTested, 0u);
    EXPECT_EQ(f0->stats.residency.requested, flatRequested);
    EXPECT_EQ(f1->stats.residency.loaded, flatLoaded);
  }
}

// Pages loaded for a view of the whole blob stay resident when the camera turns to look past its
// side, where clusters whose culling spheres stick out of their groups' are on the cut outside the
// view (the page tables' bounds do not hold them: the trees grew when their pages arrived). There
// every selection draws the same cut: without the grown bounds the traversals would cull the
// nodes of clusters the flat pass keeps.
TEST_F(ClusterResidency, TraversalsHoldTheSpheresOfArrivedPages) {
  const PagedBlob& blob = pagedWideBlob();
  const Bounds& b = blob.whole.scene.worldBounds();
  Camera whole;
  whole.eye = b.center() + glm::vec3(0.0f, 0.0f, 4.0f * b.radius());
  whole.target = b.center();
  whole.fovYDegrees = 40.0f;
  Camera side = whole; // the blob's left part (x below about a third of its radius) out of view
  side.target = b.center() + glm::vec3(1.2f * b.radius(), 0.0f, 0.0f);
  side.fovYDegrees = 25.0f;
  uint64_t budget = 64ull << 20;
  ClusterRenderOutput flat;
  for (SelectionMode selection : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag}) {
    SCOPED_TRACE(toString(selection));
    Opened o = openBudgeted(context(), budget, blob);
    ClusterRenderSettings s = viewSettings(whole);
    s.tauPixels = 0.25f;
    s.selection = selection;
    converge(*o.renderer, s, budget);
    s.base.camera = side;
    s.readVisibility = true;
    auto c = converge(*o.renderer, s, budget);
    EXPECT_EQ(c.output.stats.selection, selection);
    if (selection == SelectionMode::Flat) {
      flat = std::move(c.output);
      continue;
    }
    expectSameCut(flat, c.output, fmt::format("residency_arrived_{}", toString(selection)));
  }
}

// Auto picks the LOD BVH from kHierarchyInstances instances under a budget too: a grid of that many
// small blobs seen from low over one corner (near copies need fine pages, far ones the roots)
// converges to the flat selection's cut and image, which are the unbudgeted ones.
TEST_F(ClusterResidency, AutoPicksTheHierarchyForManyInstances) {
  static PagedBlob grid = [] {
    io::BlobOptions o;
    o.subdivisions = 5;
    lod::BuildConfig config;
    config.normalWeight = 0.0f;
    auto baked = lod::bakeLodAsset(io::generateBlob(o), config);
    if (!baked) std::abort();
    uint32_t side = 128, rows = (kHierarchyInstances + side - 1) / side;
    baked->scene.instances.clear();
    for (uint32_t i = 0; i < side * rows; ++i)
      baked->scene.instances.push_back(
          {0, glm::translate(glm::mat4(1.0f), glm::vec3(3.0f * float(i % side), 0.0f, 3.0f * float(i / side)))});
    return writePaged("grid", *baked);
  }();
  ASSERT_GE(grid.whole.scene.instances.size(), kHierarchyInstances);
  Camera cam;
  cam.eye = {-1.2f, 1.4f, -1.2f};
  cam.target = {8.0f, 0.0f, 8.0f};
  cam.fovYDegrees = 60.0f;
  ClusterRenderSettings s = viewSettings(cam);
  s.readVisibility = true;
  uint64_t budget = viewBytes(context(), s, grid) + 24 * 1024;
  ClusterRenderOutput full = test::renderCluster(context(), grid.whole, s);
  ClusterRenderOutput flat;
  for (SelectionMode selection : {SelectionMode::Flat, SelectionMode::Auto}) {
    SCOPED_TRACE(toString(selection));
    s.selection = selection;
    Opened o = openBudgeted(context(), budget, grid);
    auto c = converge(*o.renderer, s, budget);
    EXPECT_LT(c.output.stats.residency.residentPages, c.output.stats.residency.pages);
    if (selection == SelectionMode::Flat) {
      expectSameCut(full, c.output, "residency_grid_flat");
      flat = std::move(c.output);
      continue;
    }
    EXPECT_EQ(c.output.stats.selection, SelectionMode::Hierarchy);
    expectSameCut(flat, c.output, "residency_grid_auto");
  }
}

} // namespace cluster_residency_test
