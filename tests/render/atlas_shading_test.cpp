// The atlas shading stage (render/atlas_shading.h) on quads: a flat lit block equals the analytic
// colour, a lit block equals the forward renderer's pixels at the same surface points (front and
// double-sided back faces), a textured block maps the texture by its corner slots, blocks never
// write outside themselves (and read back as a region), colour-only patches equal the shading at
// the centroid, bad patches are errors. Validation must stay silent.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/color.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/render/forward_renderer.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
using mirage::shaderio::GpuAtlasPatch;
using mirage::test::GpuTest;

namespace {

// makeQuad's vertices 0 (-h,-h), 1 (h,-h), 2 (h,h), 3 (-h,h) as the slots a, b, c, d of a 2-triangle
// patch (a bottom-left ... d top-right in the quad's plane).
GpuAtlasPatch quadPatch(uint32_t firstVertex, uint32_t instance, uint32_t material, uint32_t x, uint32_t y,
                        uint32_t log2) {
  GpuAtlasPatch p{};
  p.vertices[MIRAGE_PATCH_A] = firstVertex + 0;
  p.vertices[MIRAGE_PATCH_B] = firstVertex + 1;
  p.vertices[MIRAGE_PATCH_C] = firstVertex + 3;
  p.vertices[MIRAGE_PATCH_D] = firstVertex + 2;
  p.vertices[MIRAGE_PATCH_E] = firstVertex + 0;
  p.instance = instance;
  p.material = material;
  p.triangleCount = 2;
  p.blockX = x;
  p.blockY = y;
  p.blockLog2 = log2;
  return p;
}

std::unique_ptr<AtlasShading> makeAtlas(gpu::Context& ctx, const Scene& scene, uint32_t side = 256) {
  uint32_t triangles = 0;
  for (const Instance& i : scene.instances) triangles += uint32_t(scene.meshes[i.mesh].triangleCount());
  std::vector<uint32_t> patchOf(triangles);
  for (uint32_t t = 0; t < triangles; ++t) patchOf[t] = t / 2;
  auto r = AtlasShading::create(ctx, scene, patchOf, {side, 64});
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : nullptr;
}

// The atlas bilinearly at texel position (x, y) (texel centres at .5), in linear colour.
glm::vec3 sampleLinear(const ImageRGBA8& img, float x, float y) {
  int x0 = int(std::floor(x - 0.5f)), y0 = int(std::floor(y - 0.5f));
  float fx = x - 0.5f - float(x0), fy = y - 0.5f - float(y0);
  auto at = [&](int i, int j) {
    const uint8_t* p = img.at(uint32_t(i), uint32_t(j));
    return glm::vec3(srgb8ToLinear(p[0]), srgb8ToLinear(p[1]), srgb8ToLinear(p[2]));
  };
  return glm::mix(glm::mix(at(x0, y0), at(x0 + 1, y0), fx), glm::mix(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx), fy);
}

// Block texel position of the point (px, py) of a quad of half size `half` in the slots of quadPatch.
glm::vec2 quadTexel(glm::vec2 p, float half, uint32_t log2) {
  float h = float(1u << log2);
  return glm::vec2(0.5f) + (p / half * 0.5f + 0.5f) * (h - 1.0f);
}

int maxDiff(const uint8_t* a, glm::u8vec4 b, int channels = 4) {
  int d = 0;
  for (int c = 0; c < channels; ++c) d = std::max(d, std::abs(int(a[c]) - int(b[c])));
  return d;
}

} // namespace

class AtlasShade : public GpuTest {};

TEST_F(AtlasShade, FlatLitQuadEqualsAnalyticColour) {
  // Blinn-Phong without specular: direct = base / pi * (n.l) * intensity, ambient = the
  // hemisphere's middle (n.y = 0) x base.
  Material m = test::solidMaterial({0.6f, 0.4f, 0.2f, 1});
  m.model = ShadingModel::BlinnPhong;
  m.specularColor = glm::vec3(0.0f);
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  auto atlas = makeAtlas(context(), scene);
  ASSERT_TRUE(atlas);
  AtlasLighting light;
  light.lightDirection = {0.0f, 0.6f, 0.8f};
  light.lightIntensity = 2.0f;
  GpuAtlasPatch p = quadPatch(0, 0, 0, 16, 32, 4);
  ASSERT_TRUE(atlas->shade({&p, 1}, light, {0, 0, 4}).ok());
  ImageRGBA8 img = atlas->readAtlas();
  ASSERT_EQ(img.width, 256u);
  glm::vec3 base(0.6f, 0.4f, 0.2f);
  glm::vec3 ambient = glm::mix(light.groundAmbient, light.skyAmbient, 0.5f);
  glm::vec3 linear = base / 3.14159265f * 0.8f * light.lightIntensity + ambient * base;
  glm::u8vec4 want(linearToSrgb8(linear.r), linearToSrgb8(linear.g), linearToSrgb8(linear.b), 255);
  int worst = 0;
  for (uint32_t y = 32; y < 48; ++y)
    for (uint32_t x = 16; x < 32; ++x) worst = std::max(worst, maxDiff(img.at(x, y), want));
  EXPECT_LE(worst, 1);
  EXPECT_EQ(img.at(15, 32)[3], 0); // outside the block: untouched
  EXPECT_EQ(img.at(16, 48)[3], 0);
}

namespace {

// The worst channel difference between the forward renderer's pixels on the quad (every 8th
// pixel) and the atlas block of the quad sampled at the same surface points, shaded from the
// forward camera's eye; `compared` counts the pixels.
int worstForwardDifference(gpu::Context& ctx, const Scene& scene, const RenderSettings& s, int& compared) {
  auto atlas = makeAtlas(ctx, scene);
  auto forward = ForwardRenderer::create(ctx, scene);
  if (!atlas || !forward.ok()) return 255;
  auto frame = forward.value()->render(s);
  const uint32_t log2 = 7;
  GpuAtlasPatch p = quadPatch(0, 0, 0, 128, 0, log2);
  if (!frame.ok() || !atlas->shade({&p, 1}, AtlasLighting{}, s.camera.eye).ok()) return 255; // RenderSettings' lights
  ImageRGBA8 img = atlas->readAtlas();
  glm::mat4 inv = viewFrame(withClipPlanes(s.camera, scene.worldBounds()), s.width, s.height).invViewProj;
  int worst = 0;
  compared = 0;
  for (uint32_t y = 8; y < s.height; y += 8)
    for (uint32_t x = 8; x < s.width; x += 8) {
      glm::vec2 ndc((x + 0.5f) / s.width * 2 - 1, (y + 0.5f) / s.height * 2 - 1);
      glm::vec4 a = inv * glm::vec4(ndc, 1, 1), b = inv * glm::vec4(ndc, 0.5f, 1);
      glm::vec3 o = glm::vec3(a) / a.w, dir = glm::vec3(b) / b.w - o;
      glm::vec3 hit = o - dir * (o.z / dir.z); // the plane z = 0
      if (std::abs(hit.x) > 0.95f || std::abs(hit.y) > 0.95f) continue;
      glm::vec2 t = quadTexel({hit.x, hit.y}, 1.0f, log2);
      glm::vec3 c = sampleLinear(img, 128 + t.x, t.y);
      glm::u8vec4 atlasColor(linearToSrgb8(c.r), linearToSrgb8(c.g), linearToSrgb8(c.b), 255);
      worst = std::max(worst, maxDiff(frame->srgb.at(x, y), atlasColor, 3));
      compared++;
    }
  return worst;
}

RenderSettings quadView(glm::vec3 eye) {
  RenderSettings s;
  s.width = 96;
  s.height = 96;
  s.camera.eye = eye;
  s.camera.target = {0, 0, 0};
  s.camera.fovYDegrees = 45.0f;
  return s;
}

} // namespace

TEST_F(AtlasShade, TexelsEqualTheForwardRenderAtTheSamePoints) {
  // GGX with a point light and the key light: the forward renderer's pixel at a surface point
  // equals the atlas sampled at that point (shaded from the same eye).
  Material m = test::solidMaterial({0.7f, 0.5f, 0.3f, 1});
  m.metallicFactor = 0.0f;
  m.roughnessFactor = 0.6f;
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  scene.lights.push_back({{0.6f, 0.4f, 1.0f}, {1.0f, 0.9f, 0.8f}, 2.0f, 6.0f});
  int compared = 0;
  EXPECT_LE(worstForwardDifference(context(), scene, quadView({0.3f, 0.2f, 3.0f}), compared), 2);
  EXPECT_GT(compared, 40);
}

TEST_F(AtlasShade, DoubleSidedBackFacesEqualTheForwardRender) {
  // Seen from behind, a double-sided quad is lit with its normal flipped (gl_FrontFacing in the
  // forward renderer, the winding against the eye in the atlas); a light behind it shows it.
  Material m = test::solidMaterial({0.4f, 0.6f, 0.5f, 1}, AlphaMode::Opaque, true);
  m.metallicFactor = 0.0f;
  m.roughnessFactor = 0.5f;
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  scene.lights.push_back({{-0.5f, 0.3f, -1.0f}, {1, 1, 1}, 3.0f, 6.0f});
  int compared = 0;
  EXPECT_LE(worstForwardDifference(context(), scene, quadView({-0.2f, 0.3f, -3.0f}), compared), 2);
  EXPECT_GT(compared, 40);
}

TEST_F(AtlasShade, TexturedBlockMapsTheTextureByCornerSlots) {
  // Quadrants of distinct colours (top-left red, top-right green, bottom-left blue, bottom-right
  // yellow in texture rows, v = 0 on top), shown through emission alone (black Blinn-Phong base).
  Texture tex{"quadrants", 8, 8, std::vector<uint8_t>(8 * 8 * 4), true};
  const glm::u8vec4 colors[4] = {{200, 30, 30, 255}, {30, 200, 30, 255}, {30, 30, 200, 255}, {200, 200, 30, 255}};
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 8; ++x) {
      glm::u8vec4 c = colors[(y >= 4) * 2 + (x >= 4)];
      for (int k = 0; k < 4; ++k) tex.rgba8[(y * 8 + x) * 4 + k] = c[k];
    }
  Material m = test::solidMaterial({0, 0, 0, 1});
  m.model = ShadingModel::BlinnPhong;
  m.specularColor = glm::vec3(0.0f);
  m.emissiveTexture = 0;
  m.emissiveFactor = glm::vec3(1.0f);
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  scene.textures.push_back(tex);
  auto atlas = makeAtlas(context(), scene);
  ASSERT_TRUE(atlas);
  const uint32_t h = 32, x0 = 64, y0 = 96;
  GpuAtlasPatch p = quadPatch(0, 0, 0, x0, y0, 5);
  ASSERT_TRUE(atlas->shade({&p, 1}, {}, {0, 0, 4}).ok());
  ImageRGBA8 img = atlas->readAtlas();
  // makeQuad's uvs: a (0, 1), b (1, 1), c (0, 0), d (1, 0): a's corner shows the texture's
  // bottom-left quadrant, b's bottom-right, c's top-left, d's top-right. 4 texels in, the
  // bilinear taps stay inside one quadrant.
  EXPECT_LE(maxDiff(img.at(x0 + 4, y0 + 4), colors[2]), 2) << "a: bottom-left (blue)";
  EXPECT_LE(maxDiff(img.at(x0 + h - 5, y0 + 4), colors[3]), 2) << "b: bottom-right (yellow)";
  EXPECT_LE(maxDiff(img.at(x0 + 4, y0 + h - 5), colors[0]), 2) << "c: top-left (red)";
  EXPECT_LE(maxDiff(img.at(x0 + h - 5, y0 + h - 5), colors[1]), 2) << "d: top-right (green)";
}

TEST_F(AtlasShade, BlocksNeverWriteOutsideThemselves) {
  // Two patches in adjacent blocks, one a wide 3-triangle block; shading the second leaves the
  // first's texels as they were, and nothing outside both blocks is written.
  Scene scene =
      test::makeScene({test::makeQuad(1.0f, 0.0f), test::makeQuad(1.0f, 0.5f, 1)},
                      {test::solidMaterial({0.9f, 0.1f, 0.1f, 1}), test::solidMaterial({0.1f, 0.9f, 0.1f, 1})});
  auto atlas = makeAtlas(context(), scene, 128);
  ASSERT_TRUE(atlas);
  GpuAtlasPatch first = quadPatch(0, 0, 0, 8, 8, 3); // 8 x 8 at (8, 8)
  GpuAtlasPatch wide = quadPatch(4, 1, 1, 16, 8, 3); // 16 x 8 at (16, 8): t2 = (b, e, d)
  wide.triangleCount = 3;
  wide.vertices[MIRAGE_PATCH_E] = 4 + 2; // d's vertex: t2 is degenerate in space, still a block to fill
  ASSERT_TRUE(atlas->shade({&first, 1}, {}, {0, 0, 4}).ok());
  ImageRGBA8 before = atlas->readAtlas();
  ASSERT_TRUE(atlas->shade({&wide, 1}, {}, {0, 0, 4}).ok());
  ImageRGBA8 after = atlas->readAtlas();
  for (uint32_t y = 0; y < 128; ++y)
    for (uint32_t x = 0; x < 128; ++x) {
      bool inFirst = x >= 8 && x < 16 && y >= 8 && y < 16, inWide = x >= 16 && x < 32 && y >= 8 && y < 16;
      const uint8_t* a = after.at(x, y);
      if (inFirst) {
        ASSERT_EQ(std::memcmp(a, before.at(x, y), 4), 0) << x << "," << y;
        ASSERT_GT(a[0], a[1]) << "first block is red at " << x << "," << y;
      } else if (inWide) {
        ASSERT_GT(a[1], a[0]) << "wide block is green at " << x << "," << y;
        ASSERT_EQ(a[3], 255);
      } else {
        ASSERT_EQ(a[3], 0) << "written outside the blocks at " << x << "," << y;
      }
    }
  // The dirty rectangle of both blocks reads back as the whole image's texels there.
  auto region = atlas->readAtlasRegion(8, 8, 24, 8);
  ASSERT_TRUE(region.ok()) << region.error().message;
  ASSERT_EQ(region->width, 24u);
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 24; ++x) ASSERT_EQ(std::memcmp(region->at(x, y), after.at(8 + x, 8 + y), 4), 0);
  EXPECT_FALSE(atlas->readAtlasRegion(120, 0, 16, 8).ok());
  EXPECT_FALSE(atlas->readAtlasRegion(0, 0, 0, 8).ok());
}

TEST_F(AtlasShade, ColourOnlyEqualsTheCentroidsShading) {
  // A point light makes the colour vary over the quad: the colour-only patch equals the block
  // sampled at the quad's centroid (the origin), not its corners.
  Material m = test::solidMaterial({0.5f, 0.6f, 0.7f, 1});
  m.roughnessFactor = 0.5f;
  m.metallicFactor = 0.0f;
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  scene.lights.push_back({{0.8f, -0.5f, 0.7f}, {1, 1, 1}, 3.0f, 5.0f});
  auto atlas = makeAtlas(context(), scene);
  ASSERT_TRUE(atlas);
  glm::vec3 eye(0.2f, 0.1f, 3.0f);
  const uint32_t log2 = 6;
  GpuAtlasPatch p = quadPatch(0, 0, 0, 0, 0, log2);
  ASSERT_TRUE(atlas->shade({&p, 1}, {}, eye).ok());
  ImageRGBA8 img = atlas->readAtlas();
  uint32_t id = 0;
  auto colours = atlas->shadeColours({&id, 1}, {}, eye);
  ASSERT_TRUE(colours.ok()) << colours.error().message;
  ASSERT_EQ(colours->size(), 1u);
  glm::vec2 t = quadTexel({0, 0}, 1.0f, log2);
  glm::vec3 c = sampleLinear(img, t.x, t.y);
  glm::u8vec4 centre(linearToSrgb8(c.r), linearToSrgb8(c.g), linearToSrgb8(c.b), 255);
  EXPECT_LE(maxDiff(&(*colours)[0][0], centre), 1);
  // The corners differ (the test would pass for any point otherwise).
  EXPECT_GT(maxDiff(img.at(0, 0), (*colours)[0], 3), 4);
  EXPECT_FALSE(atlas->shadeColours(std::vector<uint32_t>{7}, {}, eye).ok());
}

TEST_F(AtlasShade, BadPatchesAreErrors) {
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {});
  auto atlas = makeAtlas(context(), scene, 128);
  ASSERT_TRUE(atlas);
  GpuAtlasPatch p = quadPatch(0, 0, 0, 120, 0, 4); // leaves the 128-texel atlas
  auto st = atlas->shade({&p, 1}, {}, {0, 0, 4});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("leaves"), std::string::npos) << st.error().message;
  p = quadPatch(0, 0, 0, 0, 0, 4);
  p.vertices[MIRAGE_PATCH_D] = 4;
  EXPECT_FALSE(atlas->shade({&p, 1}, {}, {0, 0, 4}).ok());
  p = quadPatch(0, 0, 0, 0, 0, 8);
  EXPECT_FALSE(atlas->shade({&p, 1}, {}, {0, 0, 4}).ok());
  p = quadPatch(0, 1, 0, 0, 0, 4);
  EXPECT_FALSE(atlas->shade({&p, 1}, {}, {0, 0, 4}).ok());
  EXPECT_EQ(atlas->readAtlas().pixels[3], 0); // nothing was shaded
}
