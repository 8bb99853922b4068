// Forward renderer properties on hand-made scenes: what is drawn where, culling and winding,
// reverse-Z depth, alpha MASK/BLEND, auto-framing, timings. Validation must stay silent.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/render/forward_renderer.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::GpuTest;

namespace {

struct PixelRgb {
  int r, g, b;
};
PixelRgb pixelRgb(const ImageRGBA8& img, uint32_t x, uint32_t y) {
  const uint8_t* p = img.at(x, y);
  return {p[0], p[1], p[2]};
}
// Tests clear to black; every lit surface has ambient light, so it is never this dark.
bool isBackground(const ImageRGBA8& img, uint32_t x, uint32_t y) {
  PixelRgb p = pixelRgb(img, x, y);
  return p.r <= 2 && p.g <= 2 && p.b <= 2;
}

RenderOutput renderScene(gpu::Context& ctx, const Scene& scene, RenderSettings s) {
  auto renderer = ForwardRenderer::create(ctx, scene);
  EXPECT_TRUE(renderer.ok());
  auto out = renderer.value()->render(s);
  EXPECT_TRUE(out.ok()) << (out.ok() ? "" : out.error().message);
  return std::move(out).value();
}

RenderSettings frontView(uint32_t w = 128, uint32_t h = 96) {
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.camera.eye = {0, 0, 5};
  s.camera.target = {0, 0, 0};
  s.camera.fovYDegrees = 45.0f;
  s.lightDirection = {0, 0, 1}; // lights what the camera sees, so lit colours are predictable
  s.background = {0, 0, 0, 1};
  return s;
}

} // namespace

class Forward : public GpuTest {};

TEST_F(Forward, CubeCoversCentreNotCorners) {
  Scene scene = test::makeScene({test::makeCube(1.0f)}, {test::solidMaterial({0.8f, 0.1f, 0.1f, 1})});
  RenderSettings s = frontView();
  RenderOutput out = renderScene(context(), scene, s);
  ASSERT_EQ(out.srgb.width, 128u);
  PixelRgb c = pixelRgb(out.srgb, 64, 48);
  EXPECT_GT(c.r, 120);
  EXPECT_LT(c.g, c.r / 2);
  EXPECT_TRUE(isBackground(out.srgb, 0, 0));
  EXPECT_TRUE(isBackground(out.srgb, 127, 95));
  // The cube spans [-1,1] at distance 4 (front face z=1): half-height tan(22.5)*4 = 1.657 -> 1/1.657 of half the image.
  int top = -1;
  for (uint32_t y = 0; y < 96 && top < 0; ++y)
    if (!isBackground(out.srgb, 64, y)) top = int(y);
  EXPECT_NEAR(top, 48 - 48.0 / 1.657, 1.5);
  EXPECT_EQ(out.stats.drawCalls, 1u);
  EXPECT_EQ(out.stats.trianglesSubmitted, 12u);
}

TEST_F(Forward, BackFacesCulledUnlessDoubleSided) {
  // A quad facing away from the camera (rotated 180 degrees about Y).
  Mesh quad = test::makeQuad(1.0f, 0.0f);
  for (auto& p : quad.positions) p.x = -p.x, p.z = -p.z;
  for (auto& n : quad.normals) n = -n;
  // A rotation keeps the winding relative to the surface: the quad is now CCW seen from -Z only.
  RenderSettings s = frontView();
  Scene single = test::makeScene({quad}, {test::solidMaterial({0.9f, 0.9f, 0.9f, 1})});
  EXPECT_TRUE(isBackground(renderScene(context(), single, s).srgb, 64, 48));
  Scene twoSided = test::makeScene({quad}, {test::solidMaterial({0.9f, 0.9f, 0.9f, 1}, AlphaMode::Opaque, true)});
  EXPECT_FALSE(isBackground(renderScene(context(), twoSided, s).srgb, 64, 48));
}

TEST_F(Forward, MirroredInstanceStillShowsFrontFaces) {
  Scene scene = test::makeScene({test::makeCube(1.0f)}, {test::solidMaterial({0.2f, 0.8f, 0.2f, 1})});
  scene.instances[0].transform = glm::scale(glm::mat4(1.0f), glm::vec3(-1, 1, 1)); // det < 0
  RenderSettings s = frontView();
  RenderOutput out = renderScene(context(), scene, s);
  EXPECT_GT(pixelRgb(out.srgb, 64, 48).g, 120); // culling the wrong side would show the (unlit) back faces or nothing
}

TEST_F(Forward, ReverseZNearestSurfaceWins) {
  // Red quad at z=0.5 in front of a larger blue quad at z=0; draw order puts the far one last.
  Scene scene = test::makeScene({test::makeQuad(0.5f, 0.5f, 0), test::makeQuad(1.5f, 0.0f, 1)},
                                {test::solidMaterial({1, 0, 0, 1}), test::solidMaterial({0, 0, 1, 1})});
  RenderSettings s = frontView();
  RenderOutput out = renderScene(context(), scene, s);
  PixelRgb centre = pixelRgb(out.srgb, 64, 48);
  EXPECT_GT(centre.r, 150);
  EXPECT_LT(centre.b, 60);
  PixelRgb side = pixelRgb(out.srgb, 64 + 30, 48); // outside the red quad, on the blue one
  EXPECT_GT(side.b, 150);
  EXPECT_LT(side.r, 60);
}

TEST_F(Forward, AlphaMaskCutsOutTexels) {
  // A 2x2 texture: left column alpha 255, right column alpha 0.
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {test::solidMaterial({1, 1, 1, 1}, AlphaMode::Mask)});
  Texture t;
  t.name = "mask";
  t.width = t.height = 2;
  t.rgba8 = {255, 255, 255, 255, 255, 255, 255, 0, 255, 255, 255, 255, 255, 255, 255, 0};
  scene.textures.push_back(t);
  scene.materials[0].baseColorTexture = 0;
  scene.materials[0].alphaCutoff = 0.5f;
  RenderSettings s = frontView();
  RenderOutput out = renderScene(context(), scene, s);
  // Quad spans +-1 at distance 5: half-width in pixels = 48 / (tan(22.5) * 5) = 23.2.
  EXPECT_FALSE(isBackground(out.srgb, 64 - 15, 48));
  EXPECT_TRUE(isBackground(out.srgb, 64 + 15, 48));
  // Opaque ignores alpha entirely.
  scene.materials[0].alphaMode = AlphaMode::Opaque;
  EXPECT_FALSE(isBackground(renderScene(context(), scene, s).srgb, 64 + 15, 48));
}

TEST_F(Forward, BlendComposesOverOpaque) {
  // An unlit-looking setup: emissive-only materials (black base colour) give exact colours.
  Material red = test::solidMaterial({0, 0, 0, 0.5f}, AlphaMode::Blend);
  red.emissiveFactor = {1, 0, 0};
  Material blue = test::solidMaterial({0, 0, 0, 1});
  blue.emissiveFactor = {0, 0, 1};
  blue.roughnessFactor = 1.0f;
  red.roughnessFactor = 1.0f;
  Scene scene = test::makeScene({test::makeQuad(0.5f, 0.5f, 0), test::makeQuad(1.5f, 0.0f, 1)}, {red, blue});
  RenderSettings s = frontView();
  s.lightIntensity = 0.0f;
  s.skyAmbient = s.groundAmbient = glm::vec3(0.0f);
  s.readLinear = true;
  RenderOutput out = renderScene(context(), scene, s);
  const float* p = &out.linear.pixels[(48 * 128 + 64) * 4];
  // Linear result: red emissive (1,0,0) at alpha 0.5 over blue (0,0,1), plus the small F0 ambient = 0.
  EXPECT_NEAR(p[0], 0.5f, 0.01f);
  EXPECT_NEAR(p[2], 0.5f, 0.01f);
}

TEST_F(Forward, BlendSortedBackToFront) {
  // Two half-transparent emissive quads: the result depends on order (near over far).
  Material nearMat = test::solidMaterial({0, 0, 0, 0.5f}, AlphaMode::Blend);
  nearMat.emissiveFactor = {1, 0, 0};
  Material farMat = test::solidMaterial({0, 0, 0, 0.5f}, AlphaMode::Blend);
  farMat.emissiveFactor = {0, 1, 0};
  // Listed near first so that unsorted drawing would give the wrong answer.
  Scene scene = test::makeScene({test::makeQuad(0.5f, 0.5f, 0), test::makeQuad(0.5f, 0.0f, 1)}, {nearMat, farMat});
  RenderSettings s = frontView();
  s.lightIntensity = 0.0f;
  s.skyAmbient = s.groundAmbient = glm::vec3(0.0f);
  s.background = {0, 0, 0, 1};
  s.readLinear = true;
  RenderOutput out = renderScene(context(), scene, s);
  const float* p = &out.linear.pixels[(48 * 128 + 64) * 4];
  EXPECT_NEAR(p[0], 0.5f, 0.01f);  // near red on top: 0.5
  EXPECT_NEAR(p[1], 0.25f, 0.01f); // far green under it: 0.5 * 0.5
}

TEST_F(Forward, AutoCameraFramesTheScene) {
  Mesh sphere = test::makeSphere(3.0f, 24, 48);
  Scene scene = test::makeScene({sphere}, {test::solidMaterial({0.7f, 0.7f, 0.7f, 1})});
  scene.instances[0].transform = glm::translate(glm::mat4(1.0f), glm::vec3(100, -20, 7));
  for (auto [w, h] : {std::pair{160u, 90u}, std::pair{90u, 160u}}) {
    RenderSettings s;
    s.width = w;
    s.height = h;
    s.camera = autoCamera(scene.worldBounds(), float(w) / float(h));
    s.background = {0, 0, 0, 1};
    RenderOutput out = renderScene(context(), scene, s);
    uint32_t minX = w, maxX = 0, minY = h, maxY = 0;
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x)
        if (!isBackground(out.srgb, x, y)) {
          minX = std::min(minX, x), maxX = std::max(maxX, x);
          minY = std::min(minY, y), maxY = std::max(maxY, y);
        }
    ASSERT_LT(minX, maxX) << "nothing drawn at " << w << "x" << h;
    EXPECT_GT(minX, 0u);
    EXPECT_LT(maxX, w - 1);
    EXPECT_GT(minY, 0u);
    EXPECT_LT(maxY, h - 1);
    // The sphere fills most of the narrower dimension (bounding-box sphere is sqrt(3) larger).
    uint32_t narrow = std::min(w, h);
    EXPECT_GT(std::min(maxX - minX, maxY - minY), narrow * 4 / 10);
  }
}

// A generated city (wide, low, its box's top corners empty air) seen by the automatic camera in
// landscape, portrait and square frames: what is drawn spans most of the frame along one axis
// (the old camera left it at half the width and height) and stays inside the frame.
TEST_F(Forward, AutoCameraFillsTheFrameWithACity) {
  auto scene = io::generateScene("city", 1, 2);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  for (auto [w, h] : {std::pair{192u, 108u}, std::pair{108u, 192u}, std::pair{128u, 128u}}) {
    RenderSettings s;
    s.width = w;
    s.height = h;
    s.camera = autoCamera(scene->worldBounds(), float(w) / float(h));
    s.background = {0, 0, 0, 1};
    RenderOutput out = renderScene(context(), *scene, s);
    uint32_t minX = w, maxX = 0, minY = h, maxY = 0;
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x)
        if (!isBackground(out.srgb, x, y)) {
          minX = std::min(minX, x), maxX = std::max(maxX, x);
          minY = std::min(minY, y), maxY = std::max(maxY, y);
        }
    ASSERT_LT(minX, maxX) << "nothing drawn at " << w << "x" << h;
    EXPECT_GT(minX, 0u);
    EXPECT_LT(maxX, w - 1);
    EXPECT_GT(minY, 0u);
    EXPECT_LT(maxY, h - 1);
    double fillX = double(maxX - minX + 1) / w, fillY = double(maxY - minY + 1) / h;
    std::printf("city at %ux%u: drawn over %.0f %% of the width, %.0f %% of the height\n", w, h, 100 * fillX,
                100 * fillY);
    EXPECT_GE(std::max(fillX, fillY), 0.85) << w << "x" << h;
  }
}

TEST_F(Forward, ReportsGpuTimesAndRejectsBadSizes) {
  Scene scene = test::makeScene({test::makeSphere(1.0f, 16, 32)}, {});
  auto renderer = ForwardRenderer::create(context(), scene);
  ASSERT_TRUE(renderer.ok());
  RenderSettings s = frontView(64, 64);
  auto out = renderer.value()->render(s);
  ASSERT_TRUE(out.ok());
  if (context().caps().timestamps) {
    ASSERT_GE(out->stats.passTimes.size(), 3u);
    EXPECT_EQ(out->stats.passTimes[0].name, "frame");
    EXPECT_GT(out->stats.passTimes[0].milliseconds, 0.0);
  }
  if (context().caps().pipelineStatistics) {
    EXPECT_GT(out->stats.pipeline.fragmentInvocations, 0u);
  }
  s.width = 0;
  EXPECT_FALSE(renderer.value()->render(s).ok());
  s.width = kMaxRenderDimension + 1;
  EXPECT_FALSE(renderer.value()->render(s).ok());
}

TEST(Camera, ParsesAndRejects) {
  auto c = parseCamera("eye=1,2,3,target=0,0.5,0,fov=45");
  ASSERT_TRUE(c.ok());
  EXPECT_FLOAT_EQ(c->eye.y, 2.0f);
  EXPECT_FLOAT_EQ(c->target.y, 0.5f);
  EXPECT_FLOAT_EQ(c->fovYDegrees, 45.0f);
  EXPECT_TRUE(parseCamera("target=0,0,0,eye=0,0,-4").ok());
  EXPECT_FALSE(parseCamera("eye=1,2,target=0,0,0").ok());
  EXPECT_FALSE(parseCamera("eye=1,2,3").ok());
  EXPECT_FALSE(parseCamera("eye=0,0,0,target=0,0,0").ok());
  EXPECT_FALSE(parseCamera("eye=0,5,0,target=0,0,0").ok()); // parallel to up
  EXPECT_FALSE(parseCamera("eye=1,2,3,target=0,0,0,fov=500").ok());
  EXPECT_FALSE(parseCamera("eye=1,2,3,target=0,0,0,zoom=2").ok());
  EXPECT_FALSE(parseCamera("eye=nan,2,3,target=0,0,0").ok());
}

TEST(Camera, PathFromJsonAndOrbit) {
  auto dir = std::filesystem::temp_directory_path() / "mirage_camera_path_test";
  std::filesystem::create_directories(dir);
  auto write = [&](const char* name, const char* text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  auto good = loadCameraPath(write("good.json", R"({"cameras": ["eye=0,0,5,target=0,0,0",
      {"eye": [1, 2, 3], "target": [0, 0.5, 0], "fov": 45, "znear": 0.1, "zfar": 50}]})"));
  ASSERT_TRUE(good.ok()) << good.error().message;
  ASSERT_EQ(good->size(), 2u);
  EXPECT_FLOAT_EQ((*good)[1].eye.z, 3.0f);
  EXPECT_FLOAT_EQ((*good)[1].fovYDegrees, 45.0f);
  EXPECT_FLOAT_EQ((*good)[1].zfar, 50.0f);
  for (const char* bad : {"[]", "{}", "[{\"eye\": [1, 2, 3]}]", "[{\"eye\": [1, 2, 3], \"target\": [1, 2, 3]}]",
                          "[{\"eye\": [1, 2, 3], \"target\": [0, 0, 0], \"fov\": \"wide\"}]",
                          "[{\"eye\": [1, 2, 3], \"target\": [0, 0, 0], \"znear\": 2, \"zfar\": 1}]", "[3]", "[1,"}) {
    auto r = loadCameraPath(write("bad.json", bad));
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find("bad.json"), std::string::npos) << r.error().message;
  }
  EXPECT_FALSE(loadCameraPath(dir / "missing.json").ok());

  Bounds b;
  b.add({-1, 0, -2});
  b.add({1, 1, 2});
  auto orbit = orbitPath(b, 1.5f, 8);
  ASSERT_EQ(orbit.size(), 8u);
  Camera first = autoCamera(b, 1.5f);
  EXPECT_NEAR(glm::length(orbit[0].eye - first.eye), 0.0f, 1e-4f);
  glm::vec3 sum{0.0f};
  for (const Camera& c : orbit) {
    EXPECT_NEAR(glm::length(c.target - b.center()), 0.0f, 1e-5f); // around the bounds' centre
    EXPECT_NEAR(glm::length(c.eye - c.target), glm::length(first.eye - b.center()), 1e-3f);
    sum += c.eye - c.target;
  }
  EXPECT_NEAR(sum.x, 0.0f, 1e-3f); // a full turn: horizontal offsets cancel
  EXPECT_NEAR(sum.z, 0.0f, 1e-3f);
  EXPECT_FALSE(cameraPathArgument("orbit:0", b, 1.5f).ok());
  EXPECT_FALSE(cameraPathArgument("orbit:x", b, 1.5f).ok());
  EXPECT_EQ(cameraPathArgument("orbit:3", b, 1.5f)->size(), 3u);
  // fly:N: above the top, inside the footprint, looking ahead along the loop and 15 degrees down.
  auto fly = cameraPathArgument("fly:6", b, 1.5f);
  ASSERT_TRUE(fly.ok());
  ASSERT_EQ(fly->size(), 6u);
  for (size_t i = 0; i < fly->size(); ++i) {
    const Camera& c = (*fly)[i];
    EXPECT_GT(c.eye.y, b.max.y);
    EXPECT_LT(std::abs(c.eye.x), 1.0f);
    EXPECT_LT(std::abs(c.eye.z), 2.0f);
    glm::vec3 d = glm::normalize(c.target - c.eye);
    EXPECT_NEAR(std::asin(-d.y), glm::radians(15.0f), 1e-4f);
    glm::vec3 next = (*fly)[(i + 1) % fly->size()].eye - c.eye; // heading towards the next eye
    EXPECT_GT(glm::dot(glm::normalize(glm::vec2(d.x, d.z)), glm::normalize(glm::vec2(next.x, next.z))), 0.5f);
  }
  EXPECT_FALSE(cameraPathArgument("fly:0", b, 1.5f).ok());
  std::filesystem::remove_all(dir);
}

// A cut is a jump relative to the scene: steps of a moving camera below 2 % of the diagonal and
// turns below 10 degrees (together too) are not; a larger move, turn, roll or a new field of view
// is, and so is a degenerate camera.
TEST(Camera, CutIsAJumpNotAStep) {
  Bounds b;
  b.add({-50, 0, -50});
  b.add({50, 10, 50});
  float diagonal = glm::length(b.extent());
  Camera from;
  from.eye = {0, 5, 0};
  from.target = {0, 5, -1};
  auto turned = [&](float degrees, glm::vec3 axis) {
    Camera c = from;
    c.target = c.eye + glm::vec3(glm::rotate(glm::mat4(1.0f), glm::radians(degrees), axis) * glm::vec4(0, 0, -1, 0));
    return c;
  };
  Camera step = from;
  step.eye += glm::vec3(0.015f * diagonal, 0, 0);
  step.target += glm::vec3(0.015f * diagonal, 0, 0);
  EXPECT_FALSE(isCameraCut(from, from, b));
  EXPECT_FALSE(isCameraCut(from, step, b));
  EXPECT_FALSE(isCameraCut(from, turned(8.0f, {0, 1, 0}), b));
  EXPECT_FALSE(isCameraCut(from, turned(-8.0f, {1, 0, 0}), b));
  Camera jump = from;
  jump.eye += glm::vec3(0, 0, 0.03f * diagonal);
  jump.target += glm::vec3(0, 0, 0.03f * diagonal);
  EXPECT_TRUE(isCameraCut(from, jump, b));
  EXPECT_TRUE(isCameraCut(from, turned(12.0f, {0, 1, 0}), b));
  EXPECT_TRUE(isCameraCut(from, turned(12.0f, {1, 0, 0}), b));
  Camera rolled = from;
  rolled.up = glm::vec3(glm::rotate(glm::mat4(1.0f), glm::radians(12.0f), glm::vec3(0, 0, 1)) * glm::vec4(0, 1, 0, 0));
  EXPECT_TRUE(isCameraCut(from, rolled, b));
  Camera zoomed = from;
  zoomed.fovYDegrees = 50.0f;
  EXPECT_TRUE(isCameraCut(from, zoomed, b));
  Camera degenerate = from;
  degenerate.target = degenerate.eye;
  EXPECT_TRUE(isCameraCut(from, degenerate, b));
}
