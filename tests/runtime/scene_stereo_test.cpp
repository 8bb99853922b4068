// runtime::View::stereoIpd (docs/render.md, "Stereo"): cluster-LOD, surfel and forward scenes
// render both eyes side by side, the left half being the left eye. A surfel scene records its
// stereo frames in flight like a cluster-LOD one.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/scene.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "runtime/runtime_test_util.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::blobMrg;
using test::kViewHeight;
using test::kViewWidth;
namespace fs = std::filesystem;

namespace {

// A surfel-only .mrg of the blob (one per process).
const fs::path& surfelMrg() {
  static const fs::path path = [] {
    Scene scene = io::generateScene("blob", 1, 3).value();
    surfels::CaptureConfig config;
    config.resolution = 32;
    surfels::GBufferTexels texels = surfels::captureGBuffer(test::gpuContext(), scene, config).value().texels;
    surfels::SurfelCloud cloud = surfels::buildSurfelCloud(texels, surfels::farthestPointReference(texels, 2000));
    fs::path p = test::tempDir("runtime_stereo_surfels") / "s.mrg";
    if (!surfels::writeSurfelMrg(p.string(), cloud).ok()) std::abort();
    return p;
  }();
  return path;
}

} // namespace

class RuntimeStereo : public test::GpuTest {};

TEST_F(RuntimeStereo, ClusterLodRendersBothEyesSideBySide) {
  auto s = runtime::Scene::open(context(), {.input = blobMrg().string()});
  ASSERT_TRUE(s.ok()) << s.error().message;
  runtime::View view = test::viewOf(**s, kViewWidth, kViewHeight);
  view.stereoIpd = 0.3f;
  auto stereo = (*s)->render(view);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kViewWidth);
  ASSERT_EQ(stereo->srgb.height, kViewHeight);
  runtime::View left = test::viewOf(**s, kViewWidth, kViewHeight);
  left.camera = render::stereoEyes(view.camera, *view.stereoIpd)[0];
  auto mono = (*s)->render(left);
  ASSERT_TRUE(mono.ok()) << mono.error().message;
  EXPECT_GE(psnr(test::stereoHalf(stereo->srgb, 0), mono->srgb), 45.0);
}

// A scene file goes to the forward renderer, which draws both eyes side by side too.
TEST_F(RuntimeStereo, ForwardRendersBothEyesSideBySide) {
  auto s = runtime::Scene::open(context(), {.input = "gen:blob:3"});
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ((*s)->kind(), runtime::SceneKind::Forward);
  runtime::View view = test::viewOf(**s, kViewWidth, kViewHeight);
  view.stereoIpd = 0.3f;
  auto stereo = (*s)->render(view);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kViewWidth);
  ASSERT_EQ(stereo->srgb.height, kViewHeight);
  for (uint32_t e = 0; e < 2; ++e) {
    runtime::View eye = test::viewOf(**s, kViewWidth, kViewHeight);
    eye.camera = render::stereoEyes(view.camera, *view.stereoIpd)[e];
    auto mono = (*s)->render(eye);
    ASSERT_TRUE(mono.ok()) << mono.error().message;
    EXPECT_GE(psnr(test::stereoHalf(stereo->srgb, e), mono->srgb), 45.0) << "eye " << e;
  }
}

TEST_F(RuntimeStereo, SurfelSceneRendersAndRecordsBothEyes) {
  if (!context().caps().int64BufferAtomics) GTEST_SKIP() << "surfel stereo needs 64-bit buffer atomics";
  auto s = runtime::Scene::open(context(), {.input = surfelMrg().string(), .surfels = true});
  ASSERT_TRUE(s.ok()) << s.error().message;
  runtime::View view = test::viewOf(**s, kViewWidth, kViewHeight);
  view.stereoIpd = 0.3f;
  view.readLinear = true;
  auto stereo = (*s)->render(view);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kViewWidth);
  runtime::View left = test::viewOf(**s, kViewWidth, kViewHeight);
  left.camera = render::stereoEyes(view.camera, *view.stereoIpd)[0];
  auto mono = (*s)->render(left);
  ASSERT_TRUE(mono.ok()) << mono.error().message;
  EXPECT_GE(psnr(test::stereoHalf(stereo->srgb, 0), mono->srgb), 45.0);
  // The same frame recorded into two slots in flight: the same image.
  std::vector<std::vector<uint16_t>> pixels =
      test::recordFramesInFlight(test::gpuContext(), 2, 2 * kViewWidth, kViewHeight,
                                 [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                   if (Status st = (*s)->record(cmd, view, slot); !st) return st;
                                   color = (*s)->colorTarget();
                                   return Ok{};
                                 });
  ASSERT_EQ(pixels.size(), 2u);
  for (uint32_t i = 0; i < 2; ++i) ASSERT_TRUE((*s)->collect(i).ok());
  for (uint32_t i = 0; i < 2; ++i) EXPECT_EQ(test::differingChannels(pixels[i], stereo->linear.pixels), 0u);
}
