// Stereo cluster rendering (docs/render.md, "Stereo"): one selection shared by both eyes, each eye
// rasterized and resolved into its half of a side-by-side target. Each half must match a mono
// render of that eye's camera (the shared selection differs only where the nearer eye asks for a
// finer cut, well below the 45 dB bar), on every raster backend the device has and every selection.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "cluster_test_util.h"
#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kWidth = 80, kHeight = 64;

// A 3 x 3 grid of blobs: instances near the frustum sides, so that the two eyes see different
// instances (the union of the frusta matters) at different distances (so does the nearer eye).
const lod::LodAsset& gridAsset() {
  static lod::LodAsset asset = [] {
    io::BlobOptions o;
    o.subdivisions = 4;
    auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
    if (!baked) std::abort();
    lod::LodAsset a = std::move(*baked);
    a.scene.instances.clear();
    for (int z = -1; z <= 1; ++z)
      for (int x = -1; x <= 1; ++x)
        a.scene.instances.push_back({0, glm::translate(glm::mat4(1.0f), {x * 3.0f, 0.0f, z * 3.0f})});
    return a;
  }();
  return asset;
}

ImageRGBA8 half(const ImageRGBA8& image, uint32_t index) {
  ImageRGBA8 out;
  out.width = image.width / 2;
  out.height = image.height;
  out.pixels.resize(size_t(out.width) * out.height * 4);
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x)
      for (int c = 0; c < 4; ++c) out.at(x, y)[c] = image.at(x + index * out.width, y)[c];
  return out;
}

ClusterRenderSettings settings(const Camera& camera, RasterBackend backend, SelectionMode selection) {
  ClusterRenderSettings s;
  s.selection = selection;
  s.base.width = kWidth;
  s.base.height = kHeight;
  s.base.camera = camera;
  s.base.background = {0.1f, 0.2f, 0.3f, 1.0f};
  s.raster = backend;
  return s;
}

} // namespace

TEST(StereoEyes, MovesEyeAndTargetAlongTheRightVector) {
  Camera c;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  auto eyes = stereoEyes(c, 0.064f);
  // Looking down -z with +y up, right is +x: left eye at -ipd/2, right at +ipd/2, axes parallel.
  EXPECT_NEAR(eyes[0].eye.x, -0.032f, 1e-7f);
  EXPECT_NEAR(eyes[1].eye.x, 0.032f, 1e-7f);
  EXPECT_EQ(eyes[0].eye.y, 0.0f);
  EXPECT_EQ(eyes[0].eye.z, 5.0f);
  EXPECT_EQ(eyes[0].target - eyes[0].eye, c.target - c.eye);
  EXPECT_EQ(eyes[1].target - eyes[1].eye, c.target - c.eye);
  EXPECT_EQ(eyes[1].fovYDegrees, c.fovYDegrees);
}

TEST(StereoEyes, IpdMustBeFiniteAndNonNegative) {
  EXPECT_TRUE(validateIpd(0.064f).ok());
  EXPECT_TRUE(validateIpd(0.0f).ok());
  for (float bad : {-0.01f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    Status st = validateIpd(bad);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("--ipd"), std::string::npos) << st.error().message;
  }
}

class ClusterStereo : public test::GpuTest {};

TEST_F(ClusterStereo, EachHalfMatchesAMonoRenderOfThatEye) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  Camera camera = autoCamera(bounds, float(kWidth) / kHeight);
  camera.eye = glm::mix(camera.target, camera.eye, 0.6f); // close: the grid's sides leave the frame
  // A wide baseline so that the eyes' images differ visibly (a real IPD on this small scene would not).
  float ipd = 0.15f * glm::length(bounds.max - bounds.min);
  auto eyes = stereoEyes(camera, ipd);
  // Every backend with the flat pass; the traversals (which cull and project per BVH node) on one.
  std::vector<std::pair<RasterBackend, SelectionMode>> runs;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) runs.emplace_back(backend, SelectionMode::Flat);
  runs.emplace_back(runs.back().first, SelectionMode::Hierarchy);
  runs.emplace_back(runs.back().first, SelectionMode::Dag);
  for (auto [backend, selection] : runs) {
    SCOPED_TRACE(std::string(toString(backend)) + " " + toString(selection));
    ClusterRenderSettings s = settings(camera, backend, selection);
    s.stereoIpd = ipd;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    ASSERT_EQ(stereo->image.srgb.width, 2 * kWidth);
    ASSERT_EQ(stereo->image.srgb.height, kHeight);
    ImageRGBA8 halves[2] = {half(stereo->image.srgb, 0), half(stereo->image.srgb, 1)};
    EXPECT_LT(psnr(halves[0], halves[1]), 30.0) << "the eyes see the same image";
    uint64_t monoTriangles[2] = {};
    for (uint32_t e = 0; e < 2; ++e) {
      auto mono = (*renderer)->render(settings(eyes[e], backend, selection));
      ASSERT_TRUE(mono.ok()) << mono.error().message;
      monoTriangles[e] = mono->stats.trianglesRasterized;
      double db = psnr(halves[e], mono->image.srgb);
      EXPECT_GE(db, 45.0) << "eye " << e;
    }
    // One selection for both: it holds what either eye draws (union of frusta, finer of the cuts).
    EXPECT_GE(stereo->stats.trianglesRasterized, std::max(monoTriangles[0], monoTriangles[1]));
    EXPECT_LT(stereo->stats.trianglesRasterized, monoTriangles[0] + monoTriangles[1]);
  }
}

TEST_F(ClusterStereo, RefusesWhatTheSharedSelectionCannotServe) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ClusterRenderSettings s =
      settings(autoCamera((*renderer)->worldBounds(), 1.0f), RasterBackend::Auto, SelectionMode::Auto);
  s.stereoIpd = -1.0f;
  auto bad = (*renderer)->render(s);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--ipd"), std::string::npos);
  s.stereoIpd = 0.064f;
  s.occlusionCulling = true;
  auto occl = (*renderer)->render(s);
  ASSERT_FALSE(occl.ok());
  EXPECT_NE(occl.error().message.find("occlusion"), std::string::npos);
}
