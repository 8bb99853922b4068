// Forward renderer stereo and frames in flight (docs/render.md, "Stereo" and "Frames in flight"):
// each half of a stereo image equals a mono render of that eye's camera; frames recorded into every
// slot and submitted before any wait, one of them stereo (the target is replaced while the others
// are in flight), give exactly the images and stats of sequential render() calls; a visible set
// (setVisibleTriangles) draws only what it lists.
#include <gtest/gtest.h>

#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "test_support.h"
#include "mirage/core/image_metrics.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kForwardFramesWidth = 80, kForwardFramesHeight = 64;

// A cube, a sphere beside it and a half-transparent quad in front of both: the eyes see them at
// different places, the blended quad over different surfaces.
Scene stereoScene() {
  Material glass = test::solidMaterial({0.2f, 0.4f, 0.9f, 0.5f}, AlphaMode::Blend);
  Scene scene = test::makeScene(
      {test::makeCube(1.0f, 0), test::makeSphere(0.8f, 16, 32, 1), test::makeQuad(0.6f, 1.8f, 2)},
      {test::solidMaterial({0.8f, 0.3f, 0.2f, 1.0f}), test::solidMaterial({0.3f, 0.8f, 0.3f, 1.0f}), glass});
  scene.instances[1].transform = glm::translate(glm::mat4(1.0f), {2.2f, 0.0f, -1.0f});
  scene.instances[2].transform = glm::translate(glm::mat4(1.0f), {0.6f, 0.2f, 0.0f});
  return scene;
}

Camera stereoCamera() {
  Camera c;
  c.eye = {0.8f, 1.2f, 6.0f};
  c.target = {0.6f, 0.0f, 0.0f};
  c.fovYDegrees = 50.0f;
  return c;
}

RenderSettings framesSettings(const Camera& camera) {
  RenderSettings s;
  s.width = kForwardFramesWidth;
  s.height = kForwardFramesHeight;
  s.camera = camera;
  s.background = {0.1f, 0.2f, 0.3f, 1.0f};
  return s;
}

} // namespace

class ForwardFrames : public test::GpuTest {};

TEST_F(ForwardFrames, EachStereoHalfMatchesAMonoRenderOfThatEye) {
  auto renderer = ForwardRenderer::create(context(), stereoScene());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  float ipd = 0.8f; // wide, so that the halves differ visibly
  ForwardRenderSettings s{framesSettings(stereoCamera()), ipd};
  auto stereo = (*renderer)->render(s);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->srgb.width, 2 * kForwardFramesWidth);
  ASSERT_EQ(stereo->srgb.height, kForwardFramesHeight);
  ImageRGBA8 halves[2] = {test::stereoHalf(stereo->srgb, 0), test::stereoHalf(stereo->srgb, 1)};
  EXPECT_LT(psnr(halves[0], halves[1]), 30.0) << "the eyes see the same image";
  auto eyes = stereoEyes(stereoCamera(), ipd);
  uint64_t monoDraws = 0;
  for (uint32_t e = 0; e < 2; ++e) {
    auto mono = (*renderer)->render(framesSettings(eyes[e]));
    ASSERT_TRUE(mono.ok()) << mono.error().message;
    EXPECT_GE(psnr(halves[e], mono->srgb), 45.0) << "eye " << e;
    monoDraws += mono->stats.drawCalls;
  }
  EXPECT_EQ(stereo->stats.drawCalls, monoDraws); // every draw once per eye, in one pass
}

TEST_F(ForwardFrames, StereoSettingsRefusedInOneLine) {
  auto renderer = ForwardRenderer::create(context(), stereoScene());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  auto bad = (*renderer)->render(ForwardRenderSettings{framesSettings(stereoCamera()), -0.1f});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--ipd"), std::string::npos) << bad.error().message;
  RenderSettings wide = framesSettings(stereoCamera());
  wide.width = kMaxRenderDimension / 2 + 1;
  auto tooWide = (*renderer)->render(ForwardRenderSettings{wide, 0.064f});
  ASSERT_FALSE(tooWide.ok());
  EXPECT_NE(tooWide.error().message.find("--stereo"), std::string::npos) << tooWide.error().message;
}

TEST_F(ForwardFrames, ThreeFramesInFlightMatchSequentialRenders) {
  static_assert(kMaxFramesInFlight == 3);
  gpu::Context& ctx = context();
  auto sequential = ForwardRenderer::create(ctx, stereoScene());
  auto inFlight = ForwardRenderer::create(ctx, stereoScene());
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  // Three cameras; the middle frame in stereo, so its record replaces the targets the first frame
  // draws into, and the third replaces the stereo ones (both still in flight).
  std::vector<ForwardRenderSettings> frames(3);
  Camera side = stereoCamera();
  side.eye = {-4.0f, 2.0f, 3.0f};
  Camera close = stereoCamera();
  close.eye = glm::mix(close.target, close.eye, 0.6f);
  frames[0].base = framesSettings(stereoCamera());
  frames[1].base = framesSettings(close);
  frames[1].stereoIpd = 0.5f;
  frames[2].base = framesSettings(side);
  std::vector<RenderOutput> expected;
  for (ForwardRenderSettings& f : frames) {
    f.base.readLinear = true;
    auto out = (*sequential)->render(f);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expected.push_back(std::move(*out));
  }
  // The helper copies kForwardFramesWidth x kForwardFramesHeight: the stereo frame's left eye.
  std::vector<float> left;
  for (uint32_t y = 0; y < kForwardFramesHeight; ++y) {
    const float* row = &expected[1].linear.pixels[size_t(y) * 2 * kForwardFramesWidth * 4];
    left.insert(left.end(), row, row + kForwardFramesWidth * 4);
  }
  expected[1].linear.pixels = left;

  std::vector<std::vector<uint16_t>> pixels =
      test::recordFramesInFlight(ctx, kMaxFramesInFlight, kForwardFramesWidth, kForwardFramesHeight,
                                 [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                   if (Status st = (*inFlight)->record(cmd, frames[slot], slot); !st) return st;
                                   color = &(*inFlight)->colorTarget();
                                   return Ok{};
                                 });
  ASSERT_EQ(pixels.size(), size_t(kMaxFramesInFlight));
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_TRUE(out->srgb.pixels.empty()); // no readback on this path
    EXPECT_EQ(out->stats.drawCalls, expected[i].stats.drawCalls);
    EXPECT_EQ(out->stats.trianglesSubmitted, expected[i].stats.trianglesSubmitted);
    EXPECT_FALSE(out->stats.passTimes.empty());
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].linear.pixels), 0u)
        << "of " << pixels[i].size() << " channel values";
    EXPECT_FALSE((*inFlight)->collect(i).ok()); // a slot is collected once
  }
  EXPECT_FALSE((*inFlight)->record(VK_NULL_HANDLE, frames[0], kMaxFramesInFlight).ok()); // no fourth slot
}

// A visible set (a view cell's PVS): bad ID lists change nothing, an empty one draws nothing, none
// draws the whole scene again; the whole scene listed draws what no set draws.
TEST_F(ForwardFrames, VisibleTrianglesRestrictTheDrawsAndBadListsAreRefused) {
  Scene scene = stereoScene();
  auto renderer = ForwardRenderer::create(context(), scene);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  RenderSettings s = framesSettings(stereoCamera());
  s.readLinear = true;
  auto full = (*renderer)->render(s);
  ASSERT_TRUE(full.ok()) << full.error().message;
  const uint32_t total = uint32_t(scene.instancedTriangleCount());

  const std::vector<uint32_t> unsorted = {2, 1}, outside = {0, total};
  EXPECT_FALSE((*renderer)->setVisibleTriangles(&unsorted).ok());
  EXPECT_FALSE((*renderer)->setVisibleTriangles(&outside).ok());
  auto unchanged = (*renderer)->render(s);
  ASSERT_TRUE(unchanged.ok());
  EXPECT_TRUE(unchanged->linear.pixels == full->linear.pixels);

  std::vector<uint32_t> all(total);
  for (uint32_t t = 0; t < total; ++t) all[t] = t;
  ASSERT_TRUE((*renderer)->setVisibleTriangles(&all).ok());
  auto listed = (*renderer)->render(s);
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(listed->stats.trianglesSubmitted, full->stats.trianglesSubmitted);
  EXPECT_TRUE(listed->linear.pixels == full->linear.pixels);

  const std::vector<uint32_t> none;
  ASSERT_TRUE((*renderer)->setVisibleTriangles(&none).ok());
  auto empty = (*renderer)->render(s);
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(empty->stats.drawCalls, 0u);
  EXPECT_EQ(empty->stats.trianglesSubmitted, 0u);
  EXPECT_FALSE(empty->linear.pixels == full->linear.pixels);

  ASSERT_TRUE((*renderer)->setVisibleTriangles(nullptr).ok());
  auto again = (*renderer)->render(s);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->stats.drawCalls, full->stats.drawCalls);
  EXPECT_TRUE(again->linear.pixels == full->linear.pixels);
}
