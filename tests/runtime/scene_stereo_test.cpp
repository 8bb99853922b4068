// runtime::View::stereoIpd (docs/render.md, "Stereo"): cluster-LOD and forward scenes render both
// eyes side by side, the left half being the left eye.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/scene.h"
#include "runtime/runtime_test_util.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::blobMrg;
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kWidth = 64, kHeight = 48;

} // namespace

class RuntimeStereo : public test::GpuTest {};

TEST_F(RuntimeStereo, ClusterLodRendersBothEyesSideBySide) {
  auto s = runtime::Scene::open(context(), {.input = blobMrg().string()});
  ASSERT_TRUE(s.ok()) << s.error().message;
  runtime::View view = test::viewOf(**s, kWidth, kHeight);
  view.stereoIpd = 0.3f;
  auto stereo = (*s)->render(view);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kWidth);
  ASSERT_EQ(stereo->srgb.height, kHeight);
  runtime::View left = test::viewOf(**s, kWidth, kHeight);
  left.camera = render::stereoEyes(view.camera, *view.stereoIpd)[0];
  auto mono = (*s)->render(left);
  ASSERT_TRUE(mono.ok()) << mono.error().message;
  ImageRGBA8 half{kWidth, kHeight, {}};
  for (uint32_t y = 0; y < kHeight; ++y)
    half.pixels.insert(half.pixels.end(), stereo->srgb.at(0, y), stereo->srgb.at(0, y) + kWidth * 4);
  EXPECT_GE(psnr(half, mono->srgb), 45.0);
}

// A scene file goes to the forward renderer, which draws both eyes side by side too.
TEST_F(RuntimeStereo, ForwardRendersBothEyesSideBySide) {
  auto s = runtime::Scene::open(context(), {.input = "gen:blob:3"});
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ((*s)->kind(), runtime::SceneKind::Forward);
  runtime::View view = test::viewOf(**s, kWidth, kHeight);
  view.stereoIpd = 0.3f;
  auto stereo = (*s)->render(view);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kWidth);
  ASSERT_EQ(stereo->srgb.height, kHeight);
  for (uint32_t e = 0; e < 2; ++e) {
    runtime::View eye = test::viewOf(**s, kWidth, kHeight);
    eye.camera = render::stereoEyes(view.camera, *view.stereoIpd)[e];
    auto mono = (*s)->render(eye);
    ASSERT_TRUE(mono.ok()) << mono.error().message;
    ImageRGBA8 half{kWidth, kHeight, {}};
    for (uint32_t y = 0; y < kHeight; ++y)
      half.pixels.insert(half.pixels.end(), stereo->srgb.at(e * kWidth, y),
                         stereo->srgb.at(e * kWidth, y) + kWidth * 4);
    EXPECT_GE(psnr(half, mono->srgb), 45.0) << "eye " << e;
  }
}
