// Debug views of the cluster renderer (docs/render.md, "Debug views"): every pixel's colour must map
// back to what the view shows (shaderio/debug_view.h): its own cluster, its cluster's DAG level,
// the triangles per pixel of its triangle, or the samples rasterized there before the depth test,
// on every raster backend the device has.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "cluster_test_util.h"
#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/shaderio/debug_view.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kDebugWidth = 96, kDebugHeight = 72;
using DisplayRgb = std::array<int, 3>;

// The ramps hold display values: the PNG (sRGB) pixel is the value * 255 (half-float rounding: +-2).
DisplayRgb display(glm::vec3 c) {
  return {int(std::lround(c.x * 255)), int(std::lround(c.y * 255)), int(std::lround(c.z * 255))};
}
DisplayRgb displayPixel(const ImageRGBA8& image, uint32_t x, uint32_t y) {
  const uint8_t* p = image.at(x, y);
  return {p[0], p[1], p[2]};
}
int distance(DisplayRgb a, DisplayRgb b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}
constexpr int kTolerance = 2;
const DisplayRgb kDebugBackground{0, 0, 0}; // no ramp colour is black

// The step ramp's index of colour `c` (LOD level, overdraw - 1), or -1 when it is none of them.
int stepOf(DisplayRgb c) {
  for (uint32_t i = 0; i < 10; ++i)
    if (distance(c, display(sio::debugStepColor(i))) <= kTolerance) return int(i);
  return -1;
}

// log2(triangles per pixel) whose density colour is nearest to `c`.
float densityLog2Of(DisplayRgb c) {
  float best = 0, bestDistance = 1e9f;
  for (float l = MIRAGE_DEBUG_DENSITY_LOG2_MIN; l <= MIRAGE_DEBUG_DENSITY_LOG2_MAX; l += 1.0f / 64.0f) {
    float d = float(distance(c, display(sio::debugDensityColor(std::exp2(l)))));
    if (d < bestDistance) bestDistance = d, best = l;
  }
  return best;
}

ClusterRenderSettings debugSettings(const Camera& camera, RasterBackend backend, DebugView view) {
  ClusterRenderSettings s;
  s.base.width = kDebugWidth;
  s.base.height = kDebugHeight;
  s.base.camera = camera;
  s.base.background = {0, 0, 0, 1};
  s.raster = backend;
  s.debugView = view;
  return s;
}

// The blob's auto camera moved to `factor` times its distance from the centre.
Camera blobCameraAtDistance(const Bounds& bounds, float factor) {
  Camera c = autoCamera(bounds, float(kDebugWidth) / kDebugHeight);
  c.eye = c.target + (c.eye - c.target) * factor;
  c.znear = c.zfar = 0.0f; // derived from the scene for the new distance
  return c;
}

template <typename F> void forEachCovered(const ImageRGBA8& image, F f) {
  for (uint32_t y = 0; y < image.height; ++y)
    for (uint32_t x = 0; x < image.width; ++x)
      if (distance(displayPixel(image, x, y), kDebugBackground) > kTolerance) f(displayPixel(image, x, y));
}

} // namespace

TEST(DebugViewNames, ParseEveryNameAndRefuseOthersInOneLine) {
  for (const auto& e : kDebugViewNames) {
    auto v = parseDebugView(e.name);
    ASSERT_TRUE(v.ok()) << e.name;
    EXPECT_EQ(*v, e.value);
    EXPECT_STREQ(toString(e.value), e.name);
  }
  auto bad = parseDebugView("wireframe");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message, "--debug-view 'wireframe': expected none, clusters, lod, density or overdraw");
}

TEST(DebugViewRamps, StepsAndDensityHalvesAreDistinct) {
  for (uint32_t i = 0; i < 10; ++i)
    for (uint32_t j = i + 1; j < 10; ++j)
      EXPECT_GT(distance(display(sio::debugStepColor(i)), display(sio::debugStepColor(j))), 3 * kTolerance);
  EXPECT_EQ(display(sio::debugStepColor(9)), display(sio::debugStepColor(40)));
  // 1 triangle per pixel is marked: the ramp jumps there (green just below, yellow at 1).
  EXPECT_GT(distance(display(sio::debugDensityColor(0.999f)), display(sio::debugDensityColor(1.0f))), 100);
  EXPECT_EQ(display(sio::debugDensityColor(1.0f)), (DisplayRgb{255, 255, 0}));
}

class ClusterDebugView : public test::GpuTest {};

// Every covered pixel shows the colour of a cluster that owns a pixel, each such cluster shows up,
// and their colours are pairwise distinct, so neighbouring clusters differ (random colours may
// come close: a few of hundreds of clusters differ by only a few levels).
TEST_F(ClusterDebugView, ClustersViewColoursEachPixelByItsOwnCluster) {
  gpu::Context& ctx = context();
  const lod::LodAsset& asset = test::smallBlobAsset();
  ASSERT_EQ(asset.dags.size(), 1u); // mesh-local cluster ids are the global ones
  auto renderer = ClusterRenderer::create(ctx, asset);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  Camera camera = blobCameraAtDistance((*renderer)->worldBounds(), 0.8f);
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    SCOPED_TRACE(toString(backend));
    ClusterRenderSettings s = debugSettings(camera, backend, DebugView::Clusters);
    s.occlusionCulling = true; // its history names the clusters owning pixels
    s.readOwnedClusters = true;
    auto out = (*renderer)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_GT(out->ownedClusters.size(), 8u);
    std::vector<DisplayRgb> owned;
    for (auto [instance, cluster] : out->ownedClusters)
      owned.push_back(display(sio::debugClusterColor(instance, cluster)));
    for (size_t i = 0; i < owned.size(); ++i)
      for (size_t j = i + 1; j < owned.size(); ++j) ASSERT_GT(distance(owned[i], owned[j]), 0);
    std::vector<bool> seen(owned.size(), false);
    uint64_t covered = 0, unmatched = 0;
    forEachCovered(out->image.srgb, [&](DisplayRgb c) {
      ++covered;
      size_t nearest = 0;
      for (size_t i = 1; i < owned.size(); ++i)
        if (distance(owned[i], c) < distance(owned[nearest], c)) nearest = i;
      if (distance(owned[nearest], c) > kTolerance)
        ++unmatched;
      else
        seen[nearest] = true;
    });
    EXPECT_GT(covered, uint64_t(kDebugWidth * kDebugHeight / 8));
    EXPECT_EQ(unmatched, 0u);
    EXPECT_EQ(std::count(seen.begin(), seen.end(), false), 0);
  }
}

TEST_F(ClusterDebugView, LodViewShowsCoarserLevelsFarAway) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, test::smallBlobAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  uint32_t levels = uint32_t(test::smallBlobAsset().dags[0].levelCount());
  ASSERT_GT(levels, 3u);
  double meanLevel[2] = {};
  float factors[2] = {1.0f, 6.0f};
  for (int i = 0; i < 2; ++i) {
    ClusterRenderSettings s = debugSettings(blobCameraAtDistance((*renderer)->worldBounds(), factors[i]),
                                            RasterBackend::Auto, DebugView::Lod);
    auto out = (*renderer)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    uint64_t n = 0, sum = 0, unknown = 0;
    forEachCovered(out->image.srgb, [&](DisplayRgb c) {
      int level = stepOf(c);
      if (level < 0 || uint32_t(level) >= levels)
        ++unknown;
      else
        ++n, sum += uint64_t(level);
    });
    EXPECT_EQ(unknown, 0u);
    ASSERT_GT(n, 20u);
    meanLevel[i] = double(sum) / double(n);
  }
  std::printf("lod view: mean level near %.2f, far %.2f\n", meanLevel[0], meanLevel[1]);
  EXPECT_GT(meanLevel[1], meanLevel[0] + 1.0) << "near " << meanLevel[0] << ", far " << meanLevel[1];
}

// The same full-detail triangles (tau far below a pixel: level 0 near and far) three times further
// away cover a ninth of the pixels: log2 of triangles per pixel grows by about 3.2.
TEST_F(ClusterDebugView, DensityGrowsWithDistanceForTheSameTriangles) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, test::smallBlobAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  float median[2] = {};
  float factors[2] = {1.0f, 3.0f};
  for (int i = 0; i < 2; ++i) {
    ClusterRenderSettings s = debugSettings(blobCameraAtDistance((*renderer)->worldBounds(), factors[i]),
                                            RasterBackend::Auto, DebugView::Density);
    s.tauPixels = 1e-4f;
    auto out = (*renderer)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    std::vector<float> values;
    forEachCovered(out->image.srgb, [&](DisplayRgb c) { values.push_back(densityLog2Of(c)); });
    ASSERT_GT(values.size(), 20u);
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    median[i] = values[values.size() / 2];
  }
  std::printf("density view: median log2 triangles per pixel near %.2f, far %.2f\n", median[0], median[1]);
  EXPECT_GT(median[1], median[0] + 2.5f) << "near " << median[0] << ", far " << median[1];
  EXPECT_LT(median[1], median[0] + 4.0f) << "near " << median[0] << ", far " << median[1];
}

namespace {

// A square of 2 x n x n triangles, halfSize wide, in the XY plane at z, facing +Z.
Mesh square(float halfSize, float z, int n = 4) {
  Mesh m;
  m.name = "square";
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      m.positions.push_back(
          {(float(x) / float(n) * 2.0f - 1.0f) * halfSize, (float(y) / float(n) * 2.0f - 1.0f) * halfSize, z});
      m.normals.push_back({0, 0, 1});
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n) + 2, d = a + uint32_t(n) + 1;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

// Pixel of world point p in a frame of `camera` (as the renderer sets it up).
glm::uvec2 project(const Camera& camera, const Bounds& bounds, glm::vec3 p) {
  sio::ViewFrame f = viewFrame(withClipPlanes(camera, bounds), kDebugWidth, kDebugHeight);
  glm::vec4 q = f.viewProj * glm::vec4(p, 1.0f);
  glm::vec2 px = (glm::vec2(q) / q.w * 0.5f + 0.5f) * glm::vec2(kDebugWidth, kDebugHeight);
  return glm::uvec2(px);
}

} // namespace

// Square A (z = 0, x in -1..1) in front of square B (z = -1, x in 0..2): where both cover a pixel
// the count is 2 although B is hidden there (counted before the depth test); 1 where one covers
// it; background where none. The same on every backend.
TEST_F(ClusterDebugView, OverdrawCountsEverySampleBeforeTheDepthTest) {
  gpu::Context& ctx = context();
  Scene scene;
  scene.materials = {test::solidMaterial({0.5f, 0.5f, 0.5f, 1.0f}, AlphaMode::Opaque)};
  scene.meshes = {square(1.0f, 0.0f), square(1.0f, 0.0f)};
  scene.instances = {{0, glm::mat4(1.0f)}, {1, glm::translate(glm::mat4(1.0f), {1.0f, 0.0f, -1.0f})}};
  auto baked = lod::bakeLodAsset(scene, lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  auto renderer = ClusterRenderer::create(ctx, *baked);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  Camera camera;
  camera.eye = {0.5f, 0.0f, 6.0f};
  camera.target = {0.5f, 0.0f, 0.0f};
  camera.fovYDegrees = 40.0f;
  const Bounds& bounds = (*renderer)->worldBounds();
  // The eye's ray through (0.5, 0, 0) meets B at x = 0.5; through (-0.7, 0, 0) it meets z = -1 at
  // x = -0.9 (no B); B's point (1.8, 0, -1) is seen at x = 1.61 on A's plane (no A).
  glm::uvec2 both = project(camera, bounds, {0.5f, 0.1f, 0.0f});
  glm::uvec2 onlyA = project(camera, bounds, {-0.7f, 0.1f, 0.0f});
  glm::uvec2 onlyB = project(camera, bounds, {1.8f, 0.1f, -1.0f});
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    SCOPED_TRACE(toString(backend));
    auto out = (*renderer)->render(debugSettings(camera, backend, DebugView::Overdraw));
    ASSERT_TRUE(out.ok()) << out.error().message;
    const ImageRGBA8& image = out->image.srgb;
    EXPECT_EQ(stepOf(displayPixel(image, both.x, both.y)), 1) << "2 samples";
    EXPECT_EQ(stepOf(displayPixel(image, onlyA.x, onlyA.y)), 0) << "1 sample";
    EXPECT_EQ(stepOf(displayPixel(image, onlyB.x, onlyB.y)), 0) << "1 sample";
    EXPECT_EQ(displayPixel(image, 0, 0), kDebugBackground);
    // Shared edges inside a square are drawn once (top-left rule): no pixel counts 3 or more.
    uint64_t twos = 0;
    forEachCovered(image, [&](DisplayRgb c) {
      int step = stepOf(c);
      EXPECT_TRUE(step == 0 || step == 1) << step;
      twos += step == 1;
    });
    EXPECT_GT(twos, 50u);
  }
}

// Stereo debug views (compute and hybrid): each half of the side-by-side image is the mono debug
// view of that eye. With tau far below a pixel both select the full-detail clusters, so wherever
// both cover a pixel they show the same cluster, level and density, and the overdraw counts (the
// rasters count each eye into its half of one buffer) are equal everywhere.
TEST_F(ClusterDebugView, StereoHalvesAreEachEyesMonoView) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, test::smallBlobAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  Camera camera = blobCameraAtDistance(bounds, 0.8f);
  float ipd = 0.15f * glm::length(bounds.max - bounds.min); // the eyes' images differ visibly
  auto eyes = stereoEyes(camera, ipd);
  int backends = 0;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    if (backend != RasterBackend::Compute && backend != RasterBackend::Hybrid) continue;
    ++backends;
    for (DebugView view : {DebugView::Clusters, DebugView::Lod, DebugView::Density, DebugView::Overdraw}) {
      SCOPED_TRACE(std::string(toString(backend)) + " " + toString(view));
      ClusterRenderSettings s = debugSettings(camera, backend, view);
      s.tauPixels = 1e-4f;
      s.stereoIpd = ipd;
      auto stereo = (*renderer)->render(s);
      ASSERT_TRUE(stereo.ok()) << stereo.error().message;
      const ImageRGBA8& both = stereo->image.srgb;
      ASSERT_EQ(both.width, 2 * kDebugWidth);
      ASSERT_EQ(both.height, kDebugHeight);
      uint64_t eyeDiffers = 0;
      for (uint32_t y = 0; y < kDebugHeight; ++y)
        for (uint32_t x = 0; x < kDebugWidth; ++x)
          eyeDiffers += displayPixel(both, x, y) != displayPixel(both, x + kDebugWidth, y);
      EXPECT_GT(eyeDiffers, uint64_t(kDebugWidth * kDebugHeight / 20)) << "the eyes see the same image";
      for (uint32_t e = 0; e < 2; ++e) {
        ClusterRenderSettings m = debugSettings(eyes[e], backend, view);
        m.tauPixels = 1e-4f;
        auto mono = (*renderer)->render(m);
        ASSERT_TRUE(mono.ok()) << mono.error().message;
        uint64_t covered = 0, coverageDiffers = 0, colourDiffers = 0;
        for (uint32_t y = 0; y < kDebugHeight; ++y)
          for (uint32_t x = 0; x < kDebugWidth; ++x) {
            DisplayRgb a = displayPixel(both, x + e * kDebugWidth, y), b = displayPixel(mono->image.srgb, x, y);
            bool coveredA = distance(a, kDebugBackground) > kTolerance,
                 coveredB = distance(b, kDebugBackground) > kTolerance;
            if (coveredA != coveredB) {
              ++coverageDiffers;
            } else if (coveredA) {
              ++covered;
              colourDiffers += a != b;
            }
          }
        EXPECT_GT(covered, uint64_t(kDebugWidth * kDebugHeight / 8)) << "eye " << e;
        EXPECT_EQ(colourDiffers, 0u) << "eye " << e;
        // Each eye's samples land as in its mono raster: the same coverage, to a silhouette pixel.
        EXPECT_LE(coverageDiffers, view == DebugView::Overdraw ? 0u : 2u) << "eye " << e;
      }
    }
  }
  if (backends == 0) GTEST_SKIP() << "no 64-bit buffer atomics: no compute or hybrid raster";
}

TEST_F(ClusterDebugView, StereoOnTheImageBackendsRefusedInOneLine) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, test::smallBlobAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ClusterRenderSettings s = debugSettings(blobCameraAtDistance((*renderer)->worldBounds(), 1.0f),
                                          RasterBackend::Indirect, DebugView::Clusters);
  s.stereoIpd = 0.064f;
  auto out = (*renderer)->render(s);
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().message, "--debug-view clusters with --stereo needs --raster compute or hybrid, not indirect");
}
