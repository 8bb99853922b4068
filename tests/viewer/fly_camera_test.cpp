// The viewer's fly camera and the camera path writer, without a window.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mirage/gpu/swapchain.h"
#include "mirage/render/camera.h"
#include "mirage/viewer/fly_camera.h"

using namespace mirage;
using namespace mirage::viewer;

namespace {

void expectNear(glm::vec3 a, glm::vec3 b, float eps) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

Bounds unitBox() {
  Bounds b;
  b.add(glm::vec3(-1.0f));
  b.add(glm::vec3(1.0f));
  return b;
}

} // namespace

TEST(FlyCamera, DefaultLooksDownMinusZWithRightAlongPlusX) {
  FlyCamera c;
  expectNear(forwardOf(c), {0, 0, -1}, 1e-6f);
  expectNear(rightOf(c), {1, 0, 0}, 1e-6f);
}

TEST(FlyCamera, WasdQeMoveAlongTheViewAxesAtSpeedTimesSeconds) {
  FlyCamera c;
  c.yaw = 0.7f;
  c.pitch = 0.3f;
  c.speed = 2.0f;
  glm::vec3 start = c.position;
  update(c, {.move = moveAxes(true, false, false, false, false, false), .seconds = 0.5f}); // W
  expectNear(c.position - start, forwardOf(c) * 1.0f, 1e-5f);
  start = c.position;
  update(c, {.move = moveAxes(false, false, false, true, false, false), .seconds = 1.0f}); // D
  expectNear(c.position - start, rightOf(c) * 2.0f, 1e-5f);
  start = c.position;
  update(c, {.move = moveAxes(false, false, false, false, false, true), .seconds = 1.0f}); // E: up
  expectNear(c.position - start, {0, 2, 0}, 1e-5f);
  start = c.position;
  update(c, {.move = moveAxes(false, true, true, false, true, false), .seconds = 1.0f}); // A+S+Q
  expectNear(c.position - start, -rightOf(c) * 2.0f - forwardOf(c) * 2.0f - glm::vec3(0, 2, 0), 1e-5f);
  // Right is horizontal and orthogonal to forward at any pitch.
  EXPECT_NEAR(glm::dot(rightOf(c), forwardOf(c)), 0.0f, 1e-6f);
  EXPECT_EQ(rightOf(c).y, 0.0f);
}

TEST(FlyCamera, MouseRightTurnsRightMouseUpLooksUpAndPitchStopsShortOfThePoles) {
  FlyCamera c;
  update(c, {.look = {100.0f, 0.0f}});
  EXPECT_GT(forwardOf(c).x, 0.0f); // turned towards +x (the initial right)
  update(c, {.look = {0.0f, -100.0f}});
  EXPECT_GT(forwardOf(c).y, 0.0f); // screen y points down: moving up looks up
  update(c, {.look = {0.0f, -1e6f}});
  EXPECT_FLOAT_EQ(c.pitch, kPitchLimitRadians);
  update(c, {.look = {0.0f, 1e6f}});
  EXPECT_FLOAT_EQ(c.pitch, -kPitchLimitRadians);
}

TEST(FlyCamera, ScrollScalesSpeedPerNotchWithinLimits) {
  FlyCamera c;
  c.speed = 1.0f;
  update(c, {.scroll = 2.0f});
  EXPECT_NEAR(c.speed, kSpeedStepPerNotch * kSpeedStepPerNotch, 1e-5f);
  update(c, {.scroll = -2.0f});
  EXPECT_NEAR(c.speed, 1.0f, 1e-5f);
  update(c, {.scroll = -1000.0f});
  EXPECT_EQ(c.speed, kMinSpeed);
}

TEST(FlyCamera, RoundTripsARenderCamera) {
  render::Camera in;
  in.eye = {3.0f, 2.0f, -4.0f};
  in.target = {-1.0f, 0.5f, 2.0f};
  in.fovYDegrees = 47.0f;
  render::Camera out = toCamera(fromCamera(in, unitBox()));
  expectNear(out.eye, in.eye, 1e-6f);
  expectNear(out.target, in.target, 1e-4f); // same direction and focus distance
  EXPECT_EQ(out.fovYDegrees, in.fovYDegrees);
}

TEST(FlyCamera, FrameSceneIsTheAutomaticCamera) {
  Bounds b = unitBox();
  render::Camera a = render::autoCamera(b, 16.0f / 9.0f);
  render::Camera f = toCamera(frameScene(b, 16.0f / 9.0f));
  expectNear(f.eye, a.eye, 1e-5f);
  expectNear(glm::normalize(f.target - f.eye), glm::normalize(a.target - a.eye), 1e-5f);
  EXPECT_GT(frameScene(b, 1.0f).speed, 0.0f);
}

TEST(CameraString, FormatParsesBackToTheSameCamera) {
  render::Camera c;
  c.eye = {0.1f, -2.5f, 1e-3f};
  c.target = {3.14159f, 2.0f, -7.25f};
  c.up = {0.0f, 1.0f, 0.1f};
  c.fovYDegrees = 72.5f;
  auto back = render::parseCamera(render::formatCamera(c));
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->eye, c.eye);
  EXPECT_EQ(back->target, c.target);
  EXPECT_EQ(back->up, c.up);
  EXPECT_EQ(back->fovYDegrees, c.fovYDegrees);
}

TEST(CameraPathWriter, RoundTripsThroughLoadCameraPath) {
  std::vector<render::Camera> cams(3);
  for (size_t i = 0; i < cams.size(); ++i) {
    cams[i].eye = {float(i) + 0.1f, 1.0f / 3.0f, -2.0f};
    cams[i].target = {0.0f, float(i) * 0.7f, 5.0f};
    cams[i].fovYDegrees = 40.0f + float(i);
  }
  cams[1].znear = 0.01f;
  cams[1].zfar = 123.0f;
  auto path = std::filesystem::temp_directory_path() / "mirage_camera_path_test.json";
  ASSERT_TRUE(render::writeCameraPath(path, cams));
  auto back = render::loadCameraPath(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->size(), cams.size());
  for (size_t i = 0; i < cams.size(); ++i) {
    EXPECT_EQ((*back)[i].eye, cams[i].eye);
    EXPECT_EQ((*back)[i].target, cams[i].target);
    EXPECT_EQ((*back)[i].up, cams[i].up);
    EXPECT_EQ((*back)[i].fovYDegrees, cams[i].fovYDegrees);
    EXPECT_EQ((*back)[i].znear, cams[i].znear);
    EXPECT_EQ((*back)[i].zfar, cams[i].zfar);
  }
}

TEST(CameraPathWriter, UnwritableFolderIsAnErrorNamingTheFileAndLeavesNothing) {
  auto path = std::filesystem::temp_directory_path() / "mirage_no_such_folder" / "p.json";
  auto st = render::writeCameraPath(path, {render::Camera{}});
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find(path.string()), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path.parent_path()));
}

TEST(CameraPath, FrameNamesMatchRenderPath) {
  EXPECT_EQ(render::pathFrameName("out/shot.png", 7), "out/shot_0007.png");
  EXPECT_EQ(render::pathFrameName("a.png", 12345), "a_12345.png");
}

TEST(PresentMode, ParsesTheThreeNamesAndFallsBackToFifo) {
  EXPECT_EQ(*gpu::parsePresentMode("mailbox"), gpu::PresentMode::Mailbox);
  EXPECT_EQ(*gpu::parsePresentMode("immediate"), gpu::PresentMode::Immediate);
  EXPECT_EQ(*gpu::parsePresentMode("fifo"), gpu::PresentMode::Fifo);
  EXPECT_FALSE(gpu::parsePresentMode("vsync"));
  std::vector<VkPresentModeKHR> fifoOnly{VK_PRESENT_MODE_FIFO_KHR};
  std::vector<VkPresentModeKHR> all{VK_PRESENT_MODE_IMMEDIATE_KHR, VK_PRESENT_MODE_MAILBOX_KHR,
                                    VK_PRESENT_MODE_FIFO_KHR};
  EXPECT_EQ(gpu::choosePresentMode(gpu::PresentMode::Mailbox, fifoOnly), VK_PRESENT_MODE_FIFO_KHR);
  EXPECT_EQ(gpu::choosePresentMode(gpu::PresentMode::Immediate, fifoOnly), VK_PRESENT_MODE_FIFO_KHR);
  EXPECT_EQ(gpu::choosePresentMode(gpu::PresentMode::Mailbox, all), VK_PRESENT_MODE_MAILBOX_KHR);
  EXPECT_EQ(gpu::choosePresentMode(gpu::PresentMode::Immediate, all), VK_PRESENT_MODE_IMMEDIATE_KHR);
}

TEST(SurfaceFormat, PrefersEightBitUnormOverSrgb) {
  std::vector<VkSurfaceFormatKHR> formats{{VK_FORMAT_B8G8R8A8_SRGB, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR},
                                          {VK_FORMAT_B8G8R8A8_UNORM, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR}};
  EXPECT_EQ(gpu::chooseSurfaceFormat(formats).format, VK_FORMAT_B8G8R8A8_UNORM);
}
