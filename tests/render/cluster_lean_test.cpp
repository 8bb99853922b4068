// The lean compute raster (docs/render.md, "Lean raster"): clusters the selection proves small,
// unclipped and unmasked are drawn by a kernel with the per-thread 32-bit walk alone. It must write
// exactly what the general kernel writes: the same nearest depth and the same (instance, cluster,
// triangle) in every pixel of the 64-bit visibility buffer, hence the same image, in a scene where
// many clusters qualify and others do not (large triangles close up, a floor crossing the near
// plane, an alpha-masked panel), in mono, with occlusion culling's two passes, and in stereo.
// Validation must stay silent.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cstdio>
#include <cstring>
#include <set>
#include <string>
#include <utility>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "render/cluster_test_util.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::writeOnFailure;

class ClusterRenderLean : public test::GpuTest {
protected:
  void SetUp() override {
    test::GpuTest::SetUp();
    const auto& caps = context().caps();
    if (!caps.int64BufferAtomics || !caps.int64SharedAtomics) GTEST_SKIP() << "no compute raster on this device";
  }
};

namespace {

constexpr uint32_t kMaskedInstance = 5; // the checker panel (leanScene's instance order)

// Blobs (5120 triangles) from 1.6 to 9 units away: the far ones' clusters qualify, the nearest has
// triangles too large for the per-thread walk; a floor reaching behind the camera (its triangles
// cross the near plane); an alpha-masked checker panel among the blobs (never lean).
Scene leanScene() {
  io::BlobOptions o;
  o.subdivisions = 4;
  Scene s = io::generateBlob(o);
  Mesh blob = s.meshes.at(0);
  blob.material = 0;
  s.materials = {test::solidMaterial({0.7f, 0.7f, 0.75f, 1.0f}),
                 test::solidMaterial({0.3f, 0.6f, 0.3f, 1.0f}, AlphaMode::Opaque, /*doubleSided=*/true),
                 test::solidMaterial({0.9f, 0.2f, 0.2f, 1.0f}, AlphaMode::Mask, /*doubleSided=*/true)};
  s.materials[2].alphaCutoff = 0.5f;
  s.materials[2].baseColorTexture = 0;
  s.textures = {test::checkerCutout()};
  s.meshes = {blob, test::makeGrid(6.0f, 0.0f, 1, 16), test::makeGrid(0.8f, 0.0f, 2)};
  auto at = [](glm::vec3 p) { return glm::translate(glm::mat4(1.0f), p); };
  glm::mat4 floor = at({0.0f, -1.0f, 0.0f}) * glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), {1, 0, 0});
  s.instances = {{0, at({1.6f, -0.2f, 2.0f})},
                 {0, at({-2.5f, 0.2f, -2.0f})},
                 {0, at({2.5f, 0.0f, -1.0f})},
                 {0, at({0.5f, 0.5f, -5.0f})},
                 {1, floor},
                 {2, at({-0.9f, 0.3f, 0.0f})}};
  return s;
}

const lod::LodAsset& leanAsset() {
  static lod::LodAsset asset = [] {
    auto baked = lod::bakeLodAsset(leanScene(), lod::BuildConfig{});
    if (!baked) std::abort();
    return std::move(*baked);
  }();
  return asset;
}

// Low over the floor, near plane 0.05: the floor's triangles around the camera cross it.
ClusterRenderSettings leanSettings(bool lean) {
  ClusterRenderSettings s;
  s.base.width = s.base.height = test::kClusterTestSize;
  s.base.camera.eye = {0.0f, -0.7f, 4.0f};
  s.base.camera.target = {0.0f, -0.5f, 0.0f};
  s.base.camera.fovYDegrees = 70.0f;
  s.base.camera.znear = 0.05f;
  s.base.camera.zfar = 50.0f;
  s.base.background = {0.0f, 0.0f, 0.0f, 1.0f};
  s.raster = RasterBackend::Compute;
  s.leanRaster = lean;
  s.readVisibility = true;
  return s;
}

// The pixels where the two buffers differ.
size_t visibilityMismatch(const ClusterRenderOutput& a, const ClusterRenderOutput& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.visibility.size(); ++i) n += !(a.visibility[i] == b.visibility[i]);
  return n;
}

size_t imageMismatch(const ImageRGBA8& a, const ImageRGBA8& b) {
  size_t n = 0;
  for (uint32_t y = 0; y < a.height; ++y)
    for (uint32_t x = 0; x < a.width; ++x) n += std::memcmp(a.at(x, y), b.at(x, y), 4) != 0;
  return n;
}

// `lean` and `general` (one frame each, same settings but the switch) agree exactly, and the frame
// really mixes lean and general clusters, near-clipped triangles and the masked panel.
void expectSameFrame(const ClusterRenderOutput& lean, const ClusterRenderOutput& general, const std::string& what) {
  std::printf("%s: %u of %u clusters lean, %u triangles near-clipped\n", what.c_str(), lean.stats.clustersLean,
              lean.stats.clustersDrawn, lean.stats.trianglesNearClipped);
  EXPECT_EQ(general.stats.clustersLean, 0u) << what;
  EXPECT_GT(lean.stats.clustersLean, lean.stats.clustersDrawn / 4) << what; // many qualify
  EXPECT_LT(lean.stats.clustersLean, lean.stats.clustersDrawn) << what;     // not all
  EXPECT_EQ(lean.stats.clustersDrawn, general.stats.clustersDrawn) << what;
  EXPECT_EQ(lean.stats.trianglesRasterized, general.stats.trianglesRasterized) << what;
  EXPECT_GT(lean.stats.trianglesNearClipped, 0u) << what;
  EXPECT_EQ(lean.stats.trianglesNearClipped, general.stats.trianglesNearClipped) << what;
  ASSERT_EQ(lean.visibility.size(), general.visibility.size()) << what;
  std::set<uint32_t> instances;
  for (const VisibilitySample& v : lean.visibility) instances.insert(v.instance);
  EXPECT_TRUE(instances.count(kMaskedInstance)) << what << ": the masked panel covers pixels";
  EXPECT_TRUE(instances.count(UINT32_MAX)) << what << ": some background";
  EXPECT_EQ(visibilityMismatch(lean, general), 0u) << what;
  EXPECT_EQ(imageMismatch(lean.image.srgb, general.image.srgb), 0u) << what;
  writeOnFailure(lean.image.srgb, "lean_" + what + ".png");
  writeOnFailure(general.image.srgb, "general_" + what + ".png");
}

} // namespace

TEST_F(ClusterRenderLean, MatchesTheGeneralRasterExactly) {
  auto r = ClusterRenderer::create(context(), leanAsset());
  ASSERT_TRUE(r.ok()) << r.error().message;
  auto general = (*r)->render(leanSettings(false));
  ASSERT_TRUE(general.ok()) << general.error().message;
  auto lean = (*r)->render(leanSettings(true));
  ASSERT_TRUE(lean.ok()) << lean.error().message;
  expectSameFrame(*lean, *general, "mono");
}

// Occlusion culling: pass 2 appends to the lean list too. Each renderer draws the view twice (the
// second frame's pass 1 draws what the first one saw), the second frames compare.
TEST_F(ClusterRenderLean, MatchesWithOcclusionCulling) {
  ClusterRenderOutput outs[2];
  for (bool lean : {false, true}) {
    auto r = ClusterRenderer::create(context(), leanAsset());
    ASSERT_TRUE(r.ok()) << r.error().message;
    ClusterRenderSettings s = leanSettings(lean);
    s.occlusionCulling = true;
    for (int frame = 0; frame < 2; ++frame) {
      auto out = (*r)->render(s);
      ASSERT_TRUE(out.ok()) << out.error().message;
      EXPECT_TRUE(out->stats.occlusion);
      outs[lean] = std::move(*out);
    }
  }
  EXPECT_GT(outs[1].stats.clustersPass1, 0u);
  expectSameFrame(outs[1], outs[0], "occlusion");
}

// Stereo: one workgroup draws both eyes; the lean test bounds the right eye's shifted clip x too.
TEST_F(ClusterRenderLean, MatchesTheGeneralRasterInStereo) {
  auto r = ClusterRenderer::create(context(), leanAsset());
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderOutput outs[2];
  for (bool lean : {false, true}) {
    ClusterRenderSettings s = leanSettings(lean);
    s.stereoIpd = 0.3f;
    auto out = (*r)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    outs[lean] = std::move(*out);
  }
  EXPECT_EQ(outs[1].visibility.size(), size_t(2) * test::kClusterTestSize * test::kClusterTestSize);
  expectSameFrame(outs[1], outs[0], "stereo");
}

// The switch only matters to the compute backend: hybrid's down list stays the hardware one.
TEST_F(ClusterRenderLean, OnlyTheComputeBackendIsLean) {
  if (!context().caps().fragmentStoresAndAtomics) GTEST_SKIP() << "no hybrid raster";
  auto r = ClusterRenderer::create(context(), leanAsset());
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = leanSettings(true);
  s.raster = RasterBackend::Hybrid;
  auto out = (*r)->render(s);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->stats.clustersLean, 0u);
  EXPECT_GT(out->stats.clustersHardware, 0u);
}
