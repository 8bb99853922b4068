// Golden-image tests on lavapipe: fixed scenes and cameras rendered and compared against committed
// reference PNGs (tests/golden/) with SSIM >= 0.99. On failure the actual image and a difference
// image are written to build/golden-diff/. MIRAGE_UPDATE_GOLDEN=1 rewrites the references (review
// them before committing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;

namespace {

std::filesystem::path goldenDir() { return std::filesystem::path(MIRAGE_SOURCE_DIR) / "tests" / "golden"; }

void expectMatchesGolden(const std::string& name, const ImageRGBA8& actual) {
  std::filesystem::path ref = goldenDir() / (name + ".png");
  const char* update = std::getenv("MIRAGE_UPDATE_GOLDEN");
  if (update && std::string(update) == "1") {
    ASSERT_TRUE(io::writePng(ref, actual).ok());
    GTEST_SKIP() << "rewrote " << ref;
  }
  auto expected = io::readPng(ref);
  ASSERT_TRUE(expected.ok()) << "missing golden image " << ref << ": run the test with MIRAGE_UPDATE_GOLDEN=1";
  auto m = compareImages(*expected, actual);
  ASSERT_TRUE(m.ok()) << m.error().message;
  if (m->ssim < 0.99) {
    std::filesystem::path dir = std::filesystem::current_path() / "golden-diff";
    std::filesystem::create_directories(dir);
    ImageRGBA8 diff = actual;
    for (size_t i = 0; i < diff.pixels.size(); ++i)
      diff.pixels[i] =
          (i & 3) == 3 ? 255 : uint8_t(std::min(255, 4 * std::abs(int(actual.pixels[i]) - int(expected->pixels[i]))));
    (void)io::writePng(dir / (name + "-actual.png"), actual);
    (void)io::writePng(dir / (name + "-diff.png"), diff);
    ADD_FAILURE() << name << ": SSIM " << m->ssim << " < 0.99 (PSNR " << m->psnr << " dB); see " << dir;
  }
}

// A checkerboard texture (sRGB colour) and a bumpy normal map, both procedural.
Texture checker(uint32_t n) {
  Texture t{"checker", n, n, std::vector<uint8_t>(n * n * 4), true};
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      bool on = ((x / (n / 8)) + (y / (n / 8))) & 1;
      uint8_t* p = &t.rgba8[(y * n + x) * 4];
      p[0] = on ? 230 : 40, p[1] = on ? 200 : 90, p[2] = on ? 60 : 160, p[3] = 255;
    }
  return t;
}
Texture bumps(uint32_t n) {
  Texture t{"bumps", n, n, std::vector<uint8_t>(n * n * 4), false};
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      float fx = std::sin(float(x) / float(n) * 6.2831853f * 4.0f),
            fy = std::sin(float(y) / float(n) * 6.2831853f * 4.0f);
      glm::vec3 nn = glm::normalize(glm::vec3(0.6f * fx, 0.6f * fy, 1.0f));
      uint8_t* p = &t.rgba8[(y * n + x) * 4];
      p[0] = uint8_t((nn.x * 0.5f + 0.5f) * 255), p[1] = uint8_t((nn.y * 0.5f + 0.5f) * 255),
      p[2] = uint8_t((nn.z * 0.5f + 0.5f) * 255), p[3] = 255;
    }
  return t;
}
// Alpha stripes for MASK: opaque and transparent bands.
Texture stripes(uint32_t n) {
  Texture t{"stripes", n, n, std::vector<uint8_t>(n * n * 4), true};
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      uint8_t* p = &t.rgba8[(y * n + x) * 4];
      p[0] = 250, p[1] = 250, p[2] = 250, p[3] = ((x / (n / 6)) & 1) ? 0 : 255;
    }
  return t;
}

Scene materialScene() {
  std::vector<Mesh> meshes;
  std::vector<Material> mats;
  // Five spheres from rough dielectric to smooth metal.
  for (int i = 0; i < 5; ++i) {
    Material m = test::solidMaterial({0.85f, 0.45f, 0.2f, 1});
    m.metallicFactor = float(i) / 4.0f;
    m.roughnessFactor = 1.0f - 0.8f * float(i) / 4.0f;
    mats.push_back(m);
    meshes.push_back(test::makeSphere(0.45f, 24, 48, uint32_t(i)));
  }
  Material textured = test::solidMaterial({1, 1, 1, 1});
  textured.baseColorTexture = 0;
  textured.normalTexture = 1;
  mats.push_back(textured);
  meshes.push_back(test::makeCube(0.6f, 5));
  Material masked = test::solidMaterial({1, 1, 1, 1}, AlphaMode::Mask, true);
  masked.baseColorTexture = 2;
  mats.push_back(masked);
  meshes.push_back(test::makeQuad(0.7f, 0.0f, 6));
  Material glass = test::solidMaterial({0.2f, 0.5f, 1.0f, 0.4f}, AlphaMode::Blend);
  mats.push_back(glass);
  meshes.push_back(test::makeQuad(0.7f, 0.0f, 7));
  Scene s = test::makeScene(meshes, mats);
  s.textures = {checker(64), bumps(64), stripes(64)};
  for (int i = 0; i < 5; ++i)
    s.instances[i].transform = glm::translate(glm::mat4(1), glm::vec3(-2.0f + float(i), 0.5f, 0));
  s.instances[5].transform =
      glm::rotate(glm::translate(glm::mat4(1), glm::vec3(-1.2f, -0.8f, 0)), 0.6f, glm::vec3(0.3f, 1, 0));
  s.instances[6].transform = glm::translate(glm::mat4(1), glm::vec3(0.4f, -0.8f, 0));
  s.instances[7].transform = glm::translate(glm::mat4(1), glm::vec3(1.6f, -0.8f, 0.3f));
  return s;
}

RenderOutput renderWith(gpu::Context& ctx, const Scene& scene, const Camera& cam, uint32_t w, uint32_t h) {
  auto renderer = ForwardRenderer::create(ctx, scene);
  EXPECT_TRUE(renderer.ok());
  RenderSettings s;
  s.width = w;
  s.height = h;
  s.camera = cam;
  auto out = renderer.value()->render(s);
  EXPECT_TRUE(out.ok());
  return std::move(out).value();
}

} // namespace

class Golden : public test::GpuTest {};

TEST_F(Golden, Materials) {
  Camera cam;
  cam.eye = {0.3f, 0.6f, 4.2f};
  cam.target = {0, -0.1f, 0};
  cam.fovYDegrees = 55;
  expectMatchesGolden("materials", renderWith(context(), materialScene(), cam, 320, 200).srgb);
}

TEST_F(Golden, GeneratedCityAutoCamera) {
  auto scene = io::generateScene("city", 1, 2);
  ASSERT_TRUE(scene.ok());
  Camera cam = autoCamera(scene->worldBounds(), 320.0f / 200.0f);
  expectMatchesGolden("city", renderWith(context(), *scene, cam, 320, 200).srgb);
}

TEST_F(Golden, GeneratedTerrainAndBlob) {
  auto terrain = io::generateScene("terrain", 3, 129);
  ASSERT_TRUE(terrain.ok());
  expectMatchesGolden("terrain",
                      renderWith(context(), *terrain, autoCamera(terrain->worldBounds(), 1.6f), 320, 200).srgb);
  auto blob = io::generateScene("blob", 5, 4);
  ASSERT_TRUE(blob.ok());
  expectMatchesGolden("blob", renderWith(context(), *blob, autoCamera(blob->worldBounds(), 1.6f), 320, 200).srgb);
}
