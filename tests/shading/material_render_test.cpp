// Material files through the forward renderer on a lit plane, against the formulas of
// docs/shading.md evaluated on the CPU per pixel: albedo override, Blinn-Phong highlight, point
// light falloff, texture scale, detail mask 0. Ambient is off so each pixel is the direct term only.
#include <algorithm>
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/image_io.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/shading/material_file.h"
#include "lit_plane.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::GpuTest;
using namespace mirage::test;

namespace {

ImageF32 renderPlane(gpu::Context& ctx, const Plane& p) {
  auto r = ForwardRenderer::create(ctx, p.scene);
  EXPECT_TRUE(r.ok());
  auto out = r.value()->render(p.settings);
  EXPECT_TRUE(out.ok()) << (out.ok() ? "" : out.error().message);
  return out.ok() ? out->linear : ImageF32{};
}

// Blinn-Phong direct term of docs/shading.md for the plane's normal (0, 0, 1).
glm::vec3 blinnPhong(glm::vec3 albedo, glm::vec3 specular, float glossiness, glm::vec3 eye, glm::vec3 point,
                     glm::vec3 l) {
  glm::vec3 n{0, 0, 1}, v = glm::normalize(eye - point), h = glm::normalize(v + l);
  float s = std::exp2(1.0f + 10.0f * glossiness);
  float nl = std::max(glm::dot(n, l), 0.0f), nh = std::max(glm::dot(n, h), 0.0f);
  return (albedo / kPi + specular * (s + 8.0f) / (8.0f * kPi) * std::pow(nh, s)) * nl;
}

std::filesystem::path writeTextures() {
  auto dir = test::tempDir("material_render");
  ImageRGBA8 redGreen{2, 1, {255, 0, 0, 255, 0, 255, 0, 255}};
  EXPECT_TRUE(io::writePng(dir / "red_green.png", redGreen).ok());
  ImageRGBA8 black{1, 1, {0, 0, 0, 255}};
  EXPECT_TRUE(io::writePng(dir / "black.png", black).ok());
  ImageRGBA8 blue{1, 1, {0, 0, 255, 255}};
  EXPECT_TRUE(io::writePng(dir / "blue.png", blue).ok());
  return dir;
}

} // namespace

class MaterialRender : public GpuTest {};

TEST_F(MaterialRender, AlbedoOverrideMatchesAnalytic) {
  Plane p;
  p.settings.lightDirection = {0.3f, 0.2f, 1.0f};
  p.settings.lightIntensity = 2.0f;
  applyToml(p.scene, R"([[material]]
name = "clay"
model = "blinn-phong"
albedo = [0.6, 0.3, 0.1]
specular = [0, 0, 0]
[[assign]]
mesh = "plane"
use = "clay"
)");
  ImageF32 img = renderPlane(context(), p);
  glm::vec3 l = glm::normalize(p.settings.lightDirection);
  size_t n = expectPlane(p, img, [&](glm::vec3) { return glm::vec3(0.6f, 0.3f, 0.1f) / kPi * l.z * 2.0f; });
  EXPECT_GT(n, 300u);
}

TEST_F(MaterialRender, BlinnPhongHighlightMatchesAnalytic) {
  Plane p(2.0f);
  p.settings.lightDirection = {0.3f, 0.0f, 1.0f};
  p.settings.lightIntensity = 1.0f;
  applyToml(p.scene, R"([[material]]
name = "gloss"
model = "blinn-phong"
albedo = [0.2, 0.2, 0.2]
specular = [0.5, 0.5, 0.5]
glossiness = 0.5
[[assign]]
material = "*"
use = "gloss"
)");
  ImageF32 img = renderPlane(context(), p);
  glm::vec3 l = glm::normalize(p.settings.lightDirection), eye = p.settings.camera.eye;
  expectPlane(
      p, img, [&](glm::vec3 q) { return blinnPhong(glm::vec3(0.2f), glm::vec3(0.5f), 0.5f, eye, q, l); }, 0.03f);
  // The highlight sits where h = n: the mirror direction of l through the eye meets the plane at x = 3 * 0.3.
  shaderio::ViewFrame v = p.view();
  glm::vec4 clip = v.viewProj * glm::vec4(3.0f * 0.3f, 0.0f, 0.0f, 1.0f);
  float expectedX = (clip.x / clip.w * 0.5f + 0.5f) * float(kWidth);
  uint32_t row = kHeight / 2, brightest = 0;
  for (uint32_t x = 0; x < kWidth; ++x)
    if (rgbAt(img, x, row).r > rgbAt(img, brightest, row).r) brightest = x;
  EXPECT_NEAR(float(brightest) + 0.5f, expectedX, 1.0f);
  float peak = blinnPhong(glm::vec3(0.2f), glm::vec3(0.5f), 0.5f, eye, glm::vec3(0.9f, 0, 0), l).r;
  EXPECT_NEAR(rgbAt(img, brightest, row).r, peak, 0.05f * peak);
}

TEST_F(MaterialRender, PointLightFalloffMatchesAnalytic) {
  Plane p(2.0f);
  p.settings.lightIntensity = 0.0f; // the point light alone
  applyToml(p.scene, R"([[material]]
name = "matte"
model = "blinn-phong"
albedo = [1, 1, 1]
specular = [0, 0, 0]
[[assign]]
mesh = "plane"
use = "matte"
[[light]]
position = [0.5, 0, 1]
color = [1, 0.5, 0.25]
intensity = 3
radius = 2.5
)");
  ImageF32 img = renderPlane(context(), p);
  glm::vec3 light{0.5f, 0, 1}, color{1, 0.5f, 0.25f};
  size_t dark = 0;
  expectPlane(p, img, [&](glm::vec3 q) {
    dark += glm::length(light - q) >= 2.5f;
    return matteUnderPointLight(q, light, color * 3.0f, 2.5f);
  });
  EXPECT_GT(dark, 0u); // the corners lie beyond the radius: exactly black there
}

TEST_F(MaterialRender, TextureScaleTwoRepeatsTwice) {
  auto dir = writeTextures();
  auto colours = [&](const char* scale) {
    Plane p;
    p.settings.lightDirection = {0, 0, 1};
    applyToml(p.scene,
              std::string("[[material]]\nname = \"t\"\nmodel = \"blinn-phong\"\nspecular = [0, 0, 0]\n"
                          "albedo_texture = \"red_green.png\"\nalbedo_uv_scale = ") +
                  scale + "\n[[assign]]\nmesh = \"plane\"\nuse = \"t\"\n",
              dir);
    ImageF32 img = renderPlane(context(), p);
    std::string seen;
    shaderio::ViewFrame v = p.view();
    for (float u : {0.125f, 0.375f, 0.625f, 0.875f}) { // the quad's u runs along x from -1 to 1
      glm::vec4 clip = v.viewProj * glm::vec4(-1.0f + 2.0f * u, 0.0f, 0.0f, 1.0f);
      auto x = uint32_t((clip.x / clip.w * 0.5f + 0.5f) * float(kWidth));
      glm::vec3 c = rgbAt(img, x, kHeight / 2);
      // Linear filtering with repeat blends a quarter of the neighbour texel in at these u.
      seen += c.r > 2.0f * c.g ? 'R' : c.g > 2.0f * c.r ? 'G' : '?';
    }
    return seen;
  };
  EXPECT_EQ(colours("[1, 1]"), "RRGG");
  EXPECT_EQ(colours("[2, 1]"), "RGRG");
}

TEST_F(MaterialRender, DetailMaskZeroEqualsNoDetail) {
  auto dir = writeTextures();
  auto image = [&](const std::string& detail) {
    Plane p;
    applyToml(p.scene,
              "[[material]]\nname = \"d\"\nalbedo = [0.5, 0.5, 0.5]\n" + detail +
                  "[[assign]]\nmesh = \"plane\"\nuse = \"d\"\n",
              dir);
    return renderPlane(context(), p);
  };
  ImageF32 plain = image("");
  ImageF32 masked = image("detail_albedo_texture = \"blue.png\"\ndetail_mask_texture = \"black.png\"\n");
  ImageF32 unmasked = image("detail_albedo_texture = \"blue.png\"\n");
  EXPECT_EQ(plain.pixels, masked.pixels);
  EXPECT_NE(plain.pixels, unmasked.pixels); // the detail map does act where the mask lets it
  glm::vec3 c = rgbAt(unmasked, kWidth / 2, kHeight / 2);
  EXPECT_LT(c.r, 0.01f); // albedo x (2 x blue): red and green vanish
  EXPECT_GT(c.b, 0.05f);
}
