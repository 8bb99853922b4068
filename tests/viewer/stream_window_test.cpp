// The stream client's window against an in-process server: scripted input (W held, then still),
// frames arriving and drawn, the last frame equal to the lock-step client's image of the same camera,
// and with --stereo both eyes side by side. Needs an X server: tests/cli/client_window.sh runs it
// under Xvfb; without a display it skips.
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <unistd.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <glm/glm.hpp>
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "loopback_server.h"
#include "mirage/core/image_metrics.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/stream/client.h"
#include "mirage/stream/transport.h"
#include "mirage/viewer/fly_camera.h"
#include "mirage/viewer/stream_window.h"
#include "polled_input.h"

namespace mirage {
namespace {

constexpr uint32_t kWidth = 128, kHeight = 72;
constexpr char kToken[] = "window-secret";

// Pixels of `image` (or of its columns x0..x1) that are not the renderer's background, as a fraction.
double coveredFraction(const ImageRGBA8& image, uint32_t x0, uint32_t x1) {
  glm::vec4 linear = render::RenderSettings{}.background;
  auto srgb = [](float c) { return 255.0 * (c <= 0.0031308f ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055); };
  const double bg[3] = {srgb(linear.r), srgb(linear.g), srgb(linear.b)};
  size_t covered = 0;
  for (uint32_t y = 0; y < image.height; ++y)
    for (uint32_t x = x0; x < x1; ++x) {
      const uint8_t* p = image.at(x, y);
      bool differs = false;
      for (int c = 0; c < 3; ++c) differs = differs || std::abs(double(p[c]) - bg[c]) > 8.0;
      covered += differs ? 1 : 0;
    }
  return double(covered) / double(size_t(x1 - x0) * image.height);
}

stream::StreamClientOptions clientOptions(const std::string& url) {
  stream::StreamClientOptions o;
  o.url = url;
  o.token = kToken;
  o.width = kWidth;
  o.height = kHeight;
  o.capabilities = stream::kCapabilityZstdTiles;
  return o;
}

// The lock-step client's image of `camera` (one path camera through a file).
ImageRGBA8 lockStepImage(const stream::StreamClientOptions& options, const render::Camera& camera) {
  std::filesystem::path file = std::filesystem::temp_directory_path() / fmt::format("window_test_{}.json", getpid());
  EXPECT_TRUE(render::writeCameraPath(file, {camera}));
  ImageRGBA8 image;
  Status s = stream::runPathClient(test::gpuContext(), options, file.string(),
                                   [&](const stream::ClientFrameInfo&, const render::RenderOutput& out) -> Status {
                                     image = out.srgb;
                                     return Ok{};
                                   });
  std::filesystem::remove(file);
  EXPECT_TRUE(s) << s.error().message;
  return image;
}

// W held for the first display frames (at most 3, and until three server frames arrived); once three
// server frames arrived and W is up, still until three more server frames (the last answer a pose taken after the
// camera stopped), then the last frame. A display-frame bound, not a server-frame one, on the motion: the fly step
// moves by the frame's wall time, and a slow build (sanitizers) waits seconds for three frames, flying out of the
// scene. A guard ends runaway runs.
struct MoveThenSettle {
  uint64_t settledAt = 0;
  bool settled = false;
  bool operator()(uint64_t frame, uint64_t serverFrames, viewer::PolledInput& input) {
    if (frame > 5000) return false;
    bool moving = serverFrames < 3 && frame < 3;
    input.setKey(GLFW_KEY_W, moving);
    if (!moving && !settled && serverFrames >= 3) {
      settled = true;
      settledAt = serverFrames;
    }
    return !(settled && serverFrames >= settledAt + 3);
  }
};

bool haveDisplay() {
  const char* display = std::getenv("DISPLAY");
  return display && *display;
}

} // namespace

class StreamWindow : public test::GpuTest {};

namespace {

TEST_F(StreamWindow, DrawsTheFramesThatArriveWhileTheCameraFlies) {
  if (!haveDisplay()) GTEST_SKIP() << "no X server (DISPLAY unset)";
  test::StreamTestServer server("gen:city:2", stream::AtlasCodec::ZstdTiles, kToken);
  ASSERT_TRUE(server.server);
  viewer::StreamWindowOptions options;
  options.client = clientOptions(server.url());
  options.present = "immediate";
  options.captureLast = true;
  options.validation = true;
  MoveThenSettle script;
  options.script = std::ref(script);
  auto summary = viewer::runStreamWindow(options);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->validationIssues, 0u);
  EXPECT_GE(summary->serverFrames, 6u);
  EXPECT_GE(summary->posesSent, summary->serverFrames); // every frame answers a pose of its own
  EXPECT_GE(summary->displayFrames, summary->serverFrames);
  EXPECT_GT(summary->patchesHeld, 0u);
  ASSERT_EQ(summary->last.width, kWidth);
  ASSERT_EQ(summary->last.height, kHeight);
  EXPECT_GT(coveredFraction(summary->last, 0, kWidth), 0.2);

  // W took the camera forward from the start camera (frameScene of the Welcome bounds).
  {
    stream::TransportClient probe;
    auto welcome = probe.connect(server.url(), stream::transportConfig(clientOptions(server.url())));
    ASSERT_TRUE(welcome) << welcome.error().message;
    Bounds bounds;
    bounds.add(welcome->sceneMin);
    bounds.add(welcome->sceneMax);
    viewer::FlyCamera start = viewer::frameScene(bounds, float(kWidth) / kHeight);
    glm::vec3 moved = summary->camera.eye - start.position;
    EXPECT_GT(glm::dot(moved, viewer::forwardOf(start)), 0.0f);
    EXPECT_NEAR(glm::length(glm::cross(moved, viewer::forwardOf(start))), 0.0f, 1e-3f * glm::length(moved) + 1e-5f);
  }
  // What the window drew last is what a lock-step client draws for the camera W took it to.
  auto expected = lockStepImage(clientOptions(server.url()), summary->camera);
  std::printf("window %llu display frames, %llu server frames, %llu poses; PSNR vs lock-step %.2f dB\n",
              (unsigned long long)summary->displayFrames, (unsigned long long)summary->serverFrames,
              (unsigned long long)summary->posesSent, psnr(summary->last, expected));
  EXPECT_GE(psnr(summary->last, expected), 40.0);
}

TEST_F(StreamWindow, StereoDrawsBothEyesSideBySide) {
  if (!haveDisplay()) GTEST_SKIP() << "no X server (DISPLAY unset)";
  test::StreamTestServer server("gen:city:2", stream::AtlasCodec::ZstdTiles, kToken);
  ASSERT_TRUE(server.server);
  viewer::StreamWindowOptions options;
  options.client = clientOptions(server.url());
  options.client.stereoIpd = 0.5f;
  options.present = "immediate";
  options.captureLast = true;
  options.validation = true;
  MoveThenSettle script;
  options.script = std::ref(script);
  auto summary = viewer::runStreamWindow(options);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->validationIssues, 0u);
  ASSERT_EQ(summary->last.width, 2 * kWidth);
  ASSERT_EQ(summary->last.height, kHeight);
  EXPECT_GT(coveredFraction(summary->last, 0, kWidth), 0.2);
  EXPECT_GT(coveredFraction(summary->last, kWidth, 2 * kWidth), 0.2);
  // The same state as the lock-step stereo client of the last camera.
  auto lockStep = options.client;
  auto expected = lockStepImage(lockStep, summary->camera);
  ASSERT_EQ(expected.width, 2 * kWidth);
  EXPECT_GE(psnr(summary->last, expected), 40.0);
}

} // namespace
} // namespace mirage
