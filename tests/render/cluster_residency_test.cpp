// GPU residency of a paged asset read on demand (docs/render.md, "Residency"), on lavapipe with
// validation: with room for the view's pages the converged image is the unbudgeted one, a tiny
// budget gives a complete, crack-free coarser image, no frame's resident bytes exceed the budget,
// and a moving camera evicts and reloads pages while each stop converges to the unbudgeted image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "render/cluster_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kSize = 160;

class ClusterResidency : public test::GpuTest {};

// The geometric-error blob written paged with small pages (many of them), its unbudgeted
// reference (the DAG reassembled from the same pages) and the on-demand asset.
struct PagedBlob {
  std::string path;
  lod::LodAsset whole;
  uint64_t geometryBytes = 0; // every page's vertices, vertex ids and indices: the whole asset
};
const PagedBlob& pagedBlob() {
  static PagedBlob b = [] {
    PagedBlob out;
    out.path = (test::tempDir("residencyblob") / "blob.mrg").string();
    lod::LodWriteOptions o;
    o.paged = true;
    o.pages.pageBytes = 8 * 1024;
    if (!lod::saveLodAsset(out.path, test::blobAsset(), o).ok()) std::abort();
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
  }();
  return b;
}

ClusterRenderSettings viewSettings(const Camera& cam) {
  ClusterRenderSettings s;
  s.base.width = s.base.height = kSize;
  s.base.camera = cam;
  s.base.background = {0, 0, 0, 1};
  s.raster = RasterBackend::Compute;
  return s;
}

Camera overview() { return autoCamera(pagedBlob().whole.scene.worldBounds(), 1.0f); }

// A view of the blob from direction `dir` at `distance` radii, aimed `aim` radii from its centre
// towards the eye, with a vertical field of view of `fov` degrees.
Camera closeView(glm::vec3 dir, float distance, float aim, float fov) {
  Bounds b = pagedBlob().whole.scene.worldBounds();
  Camera c;
  c.target = b.center() + glm::normalize(dir) * (aim * b.radius());
  c.eye = b.center() + glm::normalize(dir) * (distance * b.radius());
  c.fovYDegrees = fov;
  if (std::abs(glm::normalize(dir).y) > 0.9f) c.up = {0, 0, 1};
  return c;
}

struct Opened {
  lod::PagedLodAsset asset;
  std::unique_ptr<ClusterRenderer> renderer;
};
Opened openBudgeted(gpu::Context& ctx, uint64_t budget) {
  Opened o;
  auto paged = lod::openPagedLodAsset(pagedBlob().path);
  EXPECT_TRUE(paged.ok()) << (paged.ok() ? "" : paged.error().message);
  o.asset = std::move(*paged);
  ClusterResidencySettings rs;
  rs.budgetBytes = budget;
  auto r = ClusterRenderer::create(ctx, o.asset, rs);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (r.ok()) o.renderer = std::move(*r);
  return o;
}

ImageRGBA8 unbudgeted(gpu::Context& ctx, const ClusterRenderSettings& s) {
  return test::renderCluster(ctx, pagedBlob().whole, s).image.srgb;
}

ClusterRenderer::Converged converge(ClusterRenderer& r, const ClusterRenderSettings& s, uint64_t budget) {
  auto c = r.renderConverged(s);
  EXPECT_TRUE(c.ok()) << (c.ok() ? "" : c.error().message);
  EXPECT_TRUE(c->converged);
  for (const ResidencyStats& f : c->frames) {
    EXPECT_LE(f.residentBytes, budget) << "a frame exceeded the budget";
    EXPECT_LE(f.geometryBytes, f.residentBytes);
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
uint64_t viewBytes(gpu::Context& ctx, const ClusterRenderSettings& s) {
  Opened o = openBudgeted(ctx, 64ull << 20);
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

// Root pages and a few units: coarser, but every pixel the full image covers (within a
// silhouette's width) is covered, and no back face shows through a crack.
TEST_F(ClusterResidency, TinyBudgetIsCompleteAndCrackFree) {
  ClusterRenderSettings s = viewSettings(overview());
  s.flagBackFaces = true;
  s.base.background = {0, 1, 0, 1};
  uint64_t budget = 4 * 24 * 1024;
  Opened o = openBudgeted(context(), budget);
  auto c = converge(*o.renderer, s, budget);
  EXPECT_LT(c.output.stats.residency.residentPages, c.output.stats.residency.pages / 2);
  const ImageRGBA8& tiny = c.output.image.srgb;
  ImageRGBA8 full = unbudgeted(context(), s);
  auto covered = [](const ImageRGBA8& img, uint32_t x, uint32_t y) {
    const uint8_t* p = img.at(x, y);
    return !(p[0] == 0 && p[1] == 255 && p[2] == 0);
  };
  size_t a = 0, differ = 0, interiorFlagged = 0;
  for (uint32_t y = 1; y + 1 < kSize; ++y)
    for (uint32_t x = 1; x + 1 < kSize; ++x) {
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
  test::writeOnFailure(tiny, "residency_tiny.png");
}

// Close views of opposite sides with room for one view's pages at a time: moving evicts, coming
// back reloads, and every stop converges to the unbudgeted image. Disabled: on this 20 k-triangle
// blob every close view needs nearly every page (both views 1.1 MB, one 1.0 MB, the reservations'
// headroom on top), so no budget separates them; it needs a scene of two meshes apart.
TEST_F(ClusterResidency, DISABLED_MovingCameraEvictsAndReloads) {
  std::vector<Camera> stops;
  for (float side : {1.0f, -1.0f, 1.0f}) stops.push_back(closeView({side, 0.2f, 0.0f}, 1.15f, 0.0f, 15.0f));
  uint64_t budget = 0;
  for (size_t i = 0; i < 2; ++i) budget = std::max(budget, viewBytes(context(), viewSettings(stops[i])));
  // Headroom for the reservations of pages not read yet (their table bound, above their exact size).
  budget += 4 * 24 * 1024;
  uint64_t both = 0; // both views' pages at once
  {
    Opened all = openBudgeted(context(), 64ull << 20);
    for (size_t i = 0; i < 2; ++i)
      both = converge(*all.renderer, viewSettings(stops[i]), 64ull << 20).output.stats.residency.residentBytes;
  }
  ASSERT_GT(both, budget) << "the budget must not hold both views";
  Opened o = openBudgeted(context(), budget);
  uint32_t evicted = 0, loadedBack = 0;
  for (size_t i = 0; i < stops.size(); ++i) {
    ClusterRenderSettings s = viewSettings(stops[i]);
    auto c = converge(*o.renderer, s, budget);
    for (const ResidencyStats& f : c.frames) {
      evicted += i > 0 ? f.evicted : 0;
      loadedBack += i == 2 ? f.loaded : 0;
    }
    expectSameImage(c.output.image.srgb, unbudgeted(context(), s), "residency_stop" + std::to_string(i));
  }
  EXPECT_GT(evicted, 0u) << "the second view needs pages the first one's evicted";
  EXPECT_GT(loadedBack, 0u) << "coming back reloads evicted pages";
}
