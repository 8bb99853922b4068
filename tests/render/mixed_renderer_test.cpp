// Mixed scenes (docs/render.md, "Mixed scenes"): the cluster renderer draws near instances as
// cluster-LOD meshes and far ones as surfels, into one visibility buffer and one resolve, with a
// complementary per-pixel dither in the band between. Checked: the union is hole-free in the band,
// the far image is the surfel-only image and the near one the mesh-only image, and a row of copies
// at increasing distances draws meshes near and surfels far (counts from the GPU stats).
// The object: blob:5 (20 480 triangles) baked in memory, and its 20k-surfel cloud (128² × 16 views,
// exact CPU farthest-point order: ~1 s on lavapipe).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"
#include "mirage/shaderio/lod_error.h"
#include "render/render_test_util.h"
#include "render/surfel_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::GpuTest;

namespace {

constexpr uint32_t kMixedSize = 192;
constexpr float kMixedSurfelSize = 2.0f;
constexpr float kBand = 0.5f;

// The object: blob:5 and its 20k-surfel cloud, and the blob's LOD asset (baked in memory).
const test::SurfelBlob& mixedBlob() { return test::denseSurfelBlob(); }
const lod::LodAsset& mixedBlobAsset() {
  static const lod::LodAsset asset = [] {
    auto baked = lod::bakeLodAsset(mixedBlob().scene, lod::BuildConfig{});
    if (!baked) std::abort();
    return std::move(*baked);
  }();
  return asset;
}

// The auto view's direction, with the eye where the reference depth (eye to the nearest point of
// the cloud's sphere) is `depthFactor` × the switch distance.
Camera mixedCameraAt(float depthFactor) {
  return test::cameraAtSwitchDepth(mixedBlob(), depthFactor, float(kMixedSize), kMixedSurfelSize);
}

float pixelScale(const Camera& c) { return shaderio::projectionScale(c.projection(1.0f)[1][1], float(kMixedSize)); }

// Hybrid with threshold 0 sends every cluster to the hardware path (its fragment shader applies the
// dither); Auto resolves to compute or hybrid wherever 64-bit atomics exist.
ClusterRenderSettings mixedSettings(const Camera& camera, RasterBackend raster = RasterBackend::Auto) {
  ClusterRenderSettings s;
  s.raster = raster;
  if (raster == RasterBackend::Hybrid) s.hybridThreshold = 0.0f;
  s.base.width = s.base.height = kMixedSize;
  s.base.camera = camera;
  s.base.background = test::kMagenta;
  s.occlusionCulling = false; // per-frame counts without history
  s.surfelSettings.surfelSize = kMixedSurfelSize;
  s.surfelSettings.fadeBand = kBand;
  return s;
}

struct Renderers {
  std::unique_ptr<ClusterRenderer> clusters;
  std::unique_ptr<SurfelRenderer> surfels;
};
Renderers makeRenderers(const std::vector<glm::mat4>& transforms) {
  Renderers r;
  r.clusters = ClusterRenderer::create(test::gpuContext(), test::placedAsset(mixedBlobAsset(), transforms)).value();
  r.surfels = SurfelRenderer::create(test::gpuContext(), mixedBlob().placed(transforms, /*linked=*/true)).value();
  return r;
}

ClusterRenderOutput renderMixed(Renderers& r, const Camera& camera, RasterBackend raster = RasterBackend::Auto) {
  ClusterRenderSettings s = mixedSettings(camera, raster);
  s.surfels = r.surfels.get();
  auto out = r.clusters->render(s);
  EXPECT_TRUE(out.ok()) << out.error().message;
  return std::move(*out);
}
ClusterRenderOutput renderMeshOnly(Renderers& r, const Camera& camera, RasterBackend raster = RasterBackend::Auto) {
  auto out = r.clusters->render(mixedSettings(camera, raster));
  EXPECT_TRUE(out.ok()) << out.error().message;
  return std::move(*out);
}

} // namespace

class MixedRender : public GpuTest {
protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!test::gpuContext().caps().int64BufferAtomics) GTEST_SKIP() << "mixed scenes need 64-bit buffer atomics";
  }
};

// In the band (fade 0.2 / 0.5 / 0.8 of the pixels to the surfels) the union covers the mesh's own
// silhouette, and each kind draws its share; with the compute rasterizer and the hardware path.
TEST_F(MixedRender, BandIsHoleFree) {
  Renderers r = makeRenderers({glm::mat4(1.0f)});
  for (RasterBackend raster : {RasterBackend::Compute, RasterBackend::Hybrid})
    for (float factor : {1.1f, 1.25f, 1.4f}) {
      SCOPED_TRACE(toString(raster));
      Camera cam = mixedCameraAt(factor);
      ClusterRenderOutput mesh = renderMeshOnly(r, cam, raster);
      ClusterRenderOutput mixed = renderMixed(r, cam, raster);
      if (raster == RasterBackend::Hybrid) {
        EXPECT_GT(mixed.stats.clustersHardware, 0u);
      }
      EXPECT_EQ(mixed.stats.surfels.fadingInstances, 1u) << factor;
      EXPECT_EQ(mixed.stats.instancesVisible, 1u) << factor; // the mesh draws its share too
      EXPECT_GT(mixed.stats.trianglesRasterized, 0u);
      size_t inside = 0, holes = 0, changed = 0;
      for (size_t i = 0; i < size_t(kMixedSize) * kMixedSize; ++i)
        if (!test::isMagenta(mesh.image.srgb, i)) {
          ++inside;
          holes += test::isMagenta(mixed.image.srgb, i);
          const uint8_t* a = &mesh.image.srgb.pixels[i * 4];
          changed += !std::equal(a, a + 3, &mixed.image.srgb.pixels[i * 4]);
        }
      ASSERT_GT(inside, 500u);
      double fraction = double(holes) / double(inside);
      RecordProperty(fmt::format("holes_{}_{}", toString(raster), factor), std::to_string(fraction));
      EXPECT_LE(fraction, 0.01) << "depth factor " << factor << ": " << holes << " of " << inside;
      // Both kinds really draw their share: the surfels' pixels (shaded from surfel positions and
      // normals, so they differ from the mesh's) are about `fade` of the silhouette. Without this a
      // mesh that ignored the dither would pass the hole check alone.
      float fade = (factor - 1.0f) / kBand;
      EXPECT_GT(mixed.stats.surfels.surfelsSplatted, 0u) << factor;
      double changedFraction = double(changed) / double(inside);
      RecordProperty(fmt::format("surfel_share_{}_{}", toString(raster), factor), std::to_string(changedFraction));
      EXPECT_NEAR(changedFraction, fade, 0.05) << "depth factor " << factor;
    }
}

// Beyond the band the mixed frame is the surfel-only frame; before it, the mesh-only frame.
TEST_F(MixedRender, FarIsSurfelsNearIsMesh) {
  Renderers r = makeRenderers({glm::mat4(1.0f)});
  Camera far = mixedCameraAt(2.0f), near = mixedCameraAt(0.8f);

  ClusterRenderOutput mixedFar = renderMixed(r, far);
  EXPECT_EQ(mixedFar.stats.instancesVisible, 0u); // fade 1: the cull pass drops the mesh
  EXPECT_EQ(mixedFar.stats.surfels.visibleInstances, 1u);
  SurfelRenderSettings ss;
  ss.base = mixedSettings(far).base;
  ss.surfelSize = kMixedSurfelSize;
  ImageRGBA8 surfelOnly = r.surfels->render(ss).value().image.srgb;
  double farSsim = ssim(mixedFar.image.srgb, surfelOnly);
  RecordProperty("far_ssim", std::to_string(farSsim));
  EXPECT_GE(farSsim, 0.99);

  ClusterRenderOutput mixedNear = renderMixed(r, near);
  EXPECT_EQ(mixedNear.stats.surfels.visibleInstances, 0u); // fade 0: no surfel drawn
  EXPECT_EQ(mixedNear.stats.instancesVisible, 1u);
  ClusterRenderOutput meshOnly = renderMeshOnly(r, near);
  EXPECT_EQ(mixedNear.image.srgb.pixels, meshOnly.image.srgb.pixels); // the same ids, the same shading
}

// A row of copies at increasing distance: meshes for the near ones, surfels for the far ones, both
// inside the band; the counts follow the fade formula per copy.
TEST_F(MixedRender, RowOfCopiesSwitchesWithDistance) {
  Camera base = mixedCameraAt(1.0f);
  glm::vec3 forward = glm::normalize(base.target - base.eye);
  float dSwitch = mixedBlob().switchDistance(pixelScale(base), kMixedSurfelSize);
  glm::vec4 s = mixedBlob().sphere();
  std::vector<glm::mat4> transforms;
  uint32_t meshExpected = 0, surfelExpected = 0, fadingExpected = 0;
  for (float factor : {0.5f, 0.8f, 1.2f, 1.3f, 1.8f, 2.5f, 4.0f}) {
    // Each copy's sphere centre at reference depth factor * dSwitch, slightly to the side.
    glm::vec3 centre = base.eye + forward * (s.w + factor * dSwitch);
    centre += glm::vec3(0.0f, 0.2f * s.w * factor, 0.0f);
    transforms.push_back(glm::translate(glm::mat4(1.0f), centre - glm::vec3(s)));
    float depth = glm::length(centre - base.eye) - s.w;
    float fade = std::clamp((depth - dSwitch) / (kBand * dSwitch), 0.0f, 1.0f);
    meshExpected += fade < 1.0f;
    surfelExpected += fade > 0.0f;
    fadingExpected += fade > 0.0f && fade < 1.0f;
  }
  Renderers r = makeRenderers(transforms);
  ClusterRenderOutput mixed = renderMixed(r, base);
  RecordProperty("mesh_instances", std::to_string(mixed.stats.instancesVisible));
  RecordProperty("surfel_instances", std::to_string(mixed.stats.surfels.visibleInstances));
  EXPECT_EQ(meshExpected, 4u); // the test's own layout: 2 mesh-only, 2 fading, 3 surfel-only
  EXPECT_EQ(fadingExpected, 2u);
  EXPECT_EQ(mixed.stats.instancesVisible, meshExpected);
  EXPECT_EQ(mixed.stats.surfels.visibleInstances, surfelExpected);
  EXPECT_EQ(mixed.stats.surfels.fadingInstances, fadingExpected);
  ClusterRenderOutput meshOnly = renderMeshOnly(r, base);
  EXPECT_EQ(meshOnly.stats.instancesVisible, transforms.size());
  EXPECT_LT(mixed.stats.trianglesRasterized, meshOnly.stats.trianglesRasterized);
}
