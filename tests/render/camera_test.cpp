// The automatic camera frames the scene's bounding box tightly for every aspect ratio and box
// shape: every corner inside the frame, the box touching both sides of the limiting axis (up to the
// margin) and centred on the other. Pure math: no GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "mirage/render/camera.h"

using namespace mirage;
using namespace mirage::render;

namespace {

struct Extent {
  glm::vec2 min{1e30f}, max{-1e30f};
};

// The box's 8 corners projected to normalized device coordinates.
Extent projectBox(const Camera& c, const Bounds& b, float aspect) {
  glm::mat4 m = c.projection(aspect) * c.view();
  Extent e;
  for (int i = 0; i < 8; ++i) {
    glm::vec3 p{(i & 1) ? b.max.x : b.min.x, (i & 2) ? b.max.y : b.min.y, (i & 4) ? b.max.z : b.min.z};
    glm::vec4 clip = m * glm::vec4(p, 1.0f);
    EXPECT_GT(clip.w, 0.0f) << "corner " << i << " behind the eye";
    float depth = clip.z / clip.w; // reverse-Z: 1 at the near plane, 0 at the far one
    EXPECT_GE(depth, 0.0f) << "corner " << i << " beyond the far plane";
    EXPECT_LE(depth, 1.0f) << "corner " << i << " before the near plane";
    glm::vec2 ndc = glm::vec2(clip) / clip.w;
    e.min = glm::min(e.min, ndc);
    e.max = glm::max(e.max, ndc);
  }
  return e;
}

Bounds box(glm::vec3 lo, glm::vec3 hi) {
  Bounds b;
  b.add(lo);
  b.add(hi);
  return b;
}

} // namespace

TEST(AutoCamera, FitsTheBoundingBoxTightlyForEveryAspectAndShape) {
  const float edge = 1.0f / kAutoCameraMargin;
  struct Case {
    const char* name;
    Bounds bounds;
  };
  Case cases[] = {
      {"cube", box({-1, -1, -1}, {1, 1, 1})},
      {"flat city", box({-46, 0, -46}, {46, 9, 46})}, // gen:city: wide and low
      {"tower", box({-1, 0, -1}, {1, 30, 1})},
      {"long street", box({-100, 0, -2}, {100, 3, 2})},
      {"far from the origin", box({1e4f, -20, 7}, {1e4f + 6, -14, 13})},
  };
  for (const Case& k : cases) {
    for (float aspect : {0.5f, 1.0f, 1.6f, 16.0f / 9.0f, 3.0f}) {
      for (float fov : {30.0f, 60.0f}) {
        SCOPED_TRACE(::testing::Message() << k.name << " aspect " << aspect << " fov " << fov);
        Camera c = autoCamera(k.bounds, aspect, fov);
        Extent e = projectBox(c, k.bounds, aspect);
        float tolerance = 2e-3f;
        // Every corner inside the frame, with the margin.
        EXPECT_LE(std::max(-e.min.x, e.max.x), edge + tolerance);
        EXPECT_LE(std::max(-e.min.y, e.max.y), edge + tolerance);
        // One axis touches both sides: the box fills the frame along it (>= 90 %), the other is centred.
        bool xTouches = e.min.x <= -edge + tolerance && e.max.x >= edge - tolerance;
        bool yTouches = e.min.y <= -edge + tolerance && e.max.y >= edge - tolerance;
        EXPECT_TRUE(xTouches || yTouches) << "x " << e.min.x << ".." << e.max.x << ", y " << e.min.y << ".." << e.max.y;
        EXPECT_GE(std::max(e.max.x - e.min.x, e.max.y - e.min.y), 2.0f * 0.9f);
        EXPECT_NEAR(e.min.x + e.max.x, 0.0f, tolerance);
        EXPECT_NEAR(e.min.y + e.max.y, 0.0f, tolerance);
      }
    }
  }
}

TEST(AutoCamera, KeepsTheThreeQuarterViewDirection) {
  Bounds b = box({-46, 0, -46}, {46, 9, 46});
  Camera c = autoCamera(b, 1.6f);
  glm::vec3 dir = glm::normalize(c.eye - c.target);
  EXPECT_NEAR(glm::dot(dir, glm::normalize(glm::vec3(1.0f, 0.75f, 1.4f))), 1.0f, 1e-5f);
}

TEST(AutoCamera, EmptyBoundsGiveAFiniteCamera) {
  Camera c = autoCamera(Bounds{}, 1.0f);
  EXPECT_TRUE(std::isfinite(c.eye.x) && std::isfinite(c.eye.y) && std::isfinite(c.eye.z));
  EXPECT_GT(glm::length(c.eye - c.target), 0.0f);
}

// Cameras that parse but make no view (the camera-path fuzz target's findings): a zero up vector
// (normalize gives NaN, which passed the parallel test), eye and target whose distance overflows,
// a view matrix that overflows, a clip plane beyond float's range; and raw bytes in a path's string
// kept out of the one-line message.
TEST(CameraParse, RejectsCamerasWithoutAFiniteView) {
  for (const char* text : {"eye=0,0,5,target=0,0,0,up=0,0,0", "eye=3e38,0,0,target=-3e38,0,0",
                           "eye=3e38,0,-3e38,target=3e38,1,-3e38,up=1,0,1"}) {
    auto c = parseCamera(text);
    EXPECT_FALSE(c.ok()) << text;
  }
  EXPECT_TRUE(parseCamera("eye=1e18,0,-1e18,target=1e18,1,-1e18,up=1,0,1").ok()); // large but finite

  auto dir = std::filesystem::temp_directory_path() / "mirage_camera_parse_test";
  std::filesystem::create_directories(dir);
  auto load = [&](const char* text) {
    std::ofstream(dir / "cams.json") << text;
    return loadCameraPath(dir / "cams.json");
  };
  auto far = load(R"([{"eye": [0, 0, 5], "target": [0, 0, 0], "znear": 1e39}])");
  ASSERT_FALSE(far.ok());
  EXPECT_NE(far.error().message.find("'znear' must be a positive finite number"), std::string::npos);
  auto raw = load("[\"eye=0,0,5,target=0,0,0,fov=\\n\\u0001\"]");
  ASSERT_FALSE(raw.ok());
  EXPECT_EQ(raw.error().message.find('\n'), std::string::npos) << raw.error().message;
  EXPECT_EQ(raw.error().message.find('\x01'), std::string::npos) << raw.error().message;
  EXPECT_NE(raw.error().message.find("cams.json: camera 0"), std::string::npos) << raw.error().message;
  std::filesystem::remove_all(dir);
}
