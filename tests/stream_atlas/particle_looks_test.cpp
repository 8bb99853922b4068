// Streamed particles' CPU side (stream/particle_looks.h): looks shared by systems with one sheet, a
// look's mip chain in its block against the sheet's texels, the frustum culling and its pixels, the
// block levels and their cap.
#include <gtest/gtest.h>

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "mirage/core/color.h"
#include "mirage/particles/sheet.h"
#include "mirage/stream/particle_looks.h"

namespace mirage::stream {
namespace {

particles::SystemDef lookSystem(const std::string& texture, uint32_t tiles, bool grey) {
  particles::SystemDef s;
  s.name = texture;
  s.sheet.texture = texture;
  s.sheet.tilesX = tiles;
  s.sheet.tilesY = tiles;
  s.sheet.alphaFromGreyscale = grey;
  return s;
}

// The tile (tx, ty)'s average over texels [x0, x0 + n) x [y0, y0 + n) of the tile, channel c.
double tileAverage(const ImageRGBA8& sheet, uint32_t tx, uint32_t ty, uint32_t x0, uint32_t y0, uint32_t n, int c) {
  double sum = 0;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      sum += sheet.at(tx * particles::kSheetTilePixels + x0 + x, ty * particles::kSheetTilePixels + y0 + y)[c];
  return sum / (255.0 * n * n);
}

shaderio::RenderParticle particleAt(glm::vec3 position, float size) {
  shaderio::RenderParticle r{};
  r.position = position;
  r.size = size;
  return r;
}

} // namespace

TEST(ParticleLooks, SystemsWithOneSheetShareTheirLooks) {
  particles::EffectFile effect;
  effect.name = "fx";
  effect.systems = {lookSystem("puff", 4, true), lookSystem("spark", 2, false), lookSystem("puff", 4, true),
                    lookSystem("puff", 4, false)};
  auto looks = ParticleLooks::build(effect);
  ASSERT_TRUE(looks) << looks.error().message;
  EXPECT_EQ(looks->lookCount(), 16u + 4u + 16u) << "the third system shares the first's; the fourth's rule differs";
  EXPECT_EQ(looks->look(0, 5), looks->look(2, 5));
  EXPECT_EQ(looks->look(0, 21), looks->look(0, 5)) << "frames wrap over the tiles";
  EXPECT_EQ(looks->look(1, 3), 19u);
  EXPECT_NE(looks->look(3, 5), looks->look(0, 5));
  effect.systems.push_back(lookSystem("lava", 2, false));
  auto bad = ParticleLooks::build(effect);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("fx"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("lava"), std::string::npos) << bad.error().message;
}

TEST(ParticleLooks, BlockHoldsTheTilesMipChain) {
  particles::EffectFile effect;
  effect.systems = {lookSystem("flame", 4, false), lookSystem("puff", 4, true)};
  auto looks = ParticleLooks::build(effect);
  ASSERT_TRUE(looks) << looks.error().message;
  auto flame = particles::generateSheet("flame", 4, 4, particles::kSheetTilePixels);
  auto puff = particles::generateSheet("puff", 4, 4, particles::kSheetTilePixels);
  ASSERT_TRUE(flame && puff);
  ImageRGBA8 atlas{128, 64, std::vector<uint8_t>(128 * 64 * 4, 7)};
  AtlasPlacement block{64, 32, 4, true}; // 32 x 16: level 0 of 16 texels, then 8, 4, 2, 1
  EXPECT_EQ(looks->write(looks->look(0, 6), block, atlas), 16u * 16 + 8 * 8 + 4 * 4 + 2 * 2 + 1);
  // Tile 6 is (2, 1). Level k's texel (i, j) averages the tile's 2^(5 - 4 + k) texels a side there.
  for (uint32_t k = 0; k <= 4; ++k) {
    uint32_t side = 16u >> k, span = particles::kSheetTilePixels / side;
    for (uint32_t j = 0; j < side; j += std::max(1u, side / 4))
      for (uint32_t i = 0; i < side; i += std::max(1u, side / 4)) {
        const uint8_t* t = atlas.at(64 + shaderio::atlasParticleLevelOffset(k, 4) + i, 32 + j);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(srgb8ToLinear(t[c]), tileAverage(*flame, 2, 1, i * span, j * span, span, c), 0.01)
              << "level " << k << " texel " << i << ", " << j;
        EXPECT_NEAR(t[3] / 255.0, tileAverage(*flame, 2, 1, i * span, j * span, span, 3), 0.5 / 255 + 1e-9);
      }
  }
  EXPECT_EQ(atlas.at(64 + 31, 32)[0], 7) << "the last column of a wide block of 16 holds nothing";
  EXPECT_EQ(atlas.at(64 + 16, 32 + 8)[0], 7) << "below level 1's 8 rows: nothing";
  EXPECT_EQ(atlas.at(63, 32)[0], 7) << "nothing outside the block";
  EXPECT_EQ(atlas.at(64, 48)[0], 7);
  // alpha_from_greyscale: white, the luminance as coverage.
  AtlasPlacement small{0, 0, 1, true};
  EXPECT_EQ(looks->write(looks->look(1, 0), small, atlas), 5u);
  for (uint32_t i = 0; i < 2; ++i) {
    const uint8_t* t = atlas.at(i, 1);
    EXPECT_EQ(t[0], 255);
    EXPECT_EQ(t[2], 255);
    double lum = 0;
    const double weights[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; ++c) lum += weights[c] * tileAverage(*puff, 0, 0, i * 16, 16, 16, c);
    EXPECT_NEAR(t[3] / 255.0, lum, 0.5 / 255 + 1e-6);
  }
  std::array<uint8_t, 4> whole = looks->colour(looks->look(0, 6));
  EXPECT_NEAR(whole[3] / 255.0, tileAverage(*flame, 2, 1, 0, 0, 32, 3), 0.5 / 255 + 1e-9) << "level 0: the average";
}

TEST(ParticleLooks, LevelTexelsStayInsideTheirLevel) {
  for (uint32_t log2 = 1; log2 <= kParticleMaxBlockLog2; ++log2)
    for (uint32_t k = 0; k <= log2; ++k) {
      float side = float((1u << log2) >> k), x0 = float(shaderio::atlasParticleLevelOffset(k, log2));
      EXPECT_LE(x0 + side, float(2u << log2)) << "level " << k << " of " << log2 << " inside the wide block";
      for (glm::vec2 uv : {glm::vec2(-0.5f, 0.0f), glm::vec2(0.0f, 1.0f), glm::vec2(0.5f), glm::vec2(1.0f, 2.0f)}) {
        glm::vec2 t = shaderio::atlasParticleLevelTexel(uv, log2, k);
        EXPECT_GE(t.x, x0 + 0.5f); // a bilinear tap's texels lie inside the level
        EXPECT_LE(t.x, x0 + side - 0.5f);
        EXPECT_GE(t.y, 0.5f);
        EXPECT_LE(t.y, side - 0.5f);
      }
      glm::vec2 middle = shaderio::atlasParticleLevelTexel(glm::vec2(0.5f), log2, k);
      EXPECT_FLOAT_EQ(middle.x, x0 + 0.5f * side);
    }
}

TEST(ParticleLooks, VisibleParticlesAndTheirPixels) {
  ParticleView v;
  v.view = glm::lookAt(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0.0f, 1.0f, 0.0f));
  v.proj = glm::perspective(glm::radians(90.0f), 1.0f, 0.1f, 100.0f); // the frustum's sides at |x| = -z
  v.viewportHeight = 200.0f;
  std::vector<shaderio::RenderParticle> records = {
      particleAt({0.0f, 0.0f, -10.0f}, 1.0f),  // centred: 1 unit at 10 = 10 pixels
      particleAt({0.0f, 0.0f, 10.0f}, 1.0f),   // behind the eye
      particleAt({12.0f, 0.0f, -10.0f}, 1.0f), // 2 units outside the right plane
      particleAt({10.5f, 0.0f, -10.0f}, 1.0f), // its sphere (0.71) reaches 0.35 units inside (distance 0.35)
      particleAt({0.0f, 0.0f, 0.05f}, 1.0f),   // its centre behind the eye plane
      particleAt({0.0f, -15.0f, -10.0f}, 1.0f)};
  std::vector<VisibleParticle> seen = visibleParticles(records, {&v, 1});
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].record, 0u);
  EXPECT_NEAR(seen[0].pixels, 10.0f, 1e-4f);
  EXPECT_EQ(seen[1].record, 3u);
  // A second view sees the one behind the first; the pixels are the larger view's.
  ParticleView back = v;
  back.view = glm::lookAt(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, 1.0f), glm::vec3(0.0f, 1.0f, 0.0f));
  back.viewportHeight = 400.0f;
  ParticleView both[2] = {v, back};
  seen = visibleParticles(records, both);
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[1].record, 1u);
  EXPECT_NEAR(seen[1].pixels, 20.0f, 1e-4f);
  EXPECT_EQ(seen[3].record, 4u) << "in front of the second eye";
  // A sub-pixel particle just outside the side plane counts when grown to 1.5 pixels.
  records = {particleAt({10.03f, 0.0f, -10.0f}, 0.01f)}; // 0.1 pixels: grown 15 times
  EXPECT_EQ(visibleParticles(records, {&v, 1}).size(), 1u);
  records = {particleAt({10.2f, 0.0f, -10.0f}, 0.01f)};
  EXPECT_EQ(visibleParticles(records, {&v, 1}).size(), 0u);
}

TEST(ParticleLooks, BlockLevelsStopAtTheTile) {
  EXPECT_EQ(particleBlockLog2(0.0f, 0.0f), uint32_t(MIRAGE_ATLAS_MIN_BLOCK_LOG2));
  EXPECT_EQ(particleBlockLog2(15.0f, 0.0f), 4u); // 16 texels span 15 pixels
  EXPECT_EQ(particleBlockLog2(16.0f, 0.0f), 5u);
  EXPECT_EQ(particleBlockLog2(500.0f, 0.0f), kParticleMaxBlockLog2) << "a tile's 32 texels at most";
  EXPECT_EQ(particleBlockLog2(INFINITY, 0.0f), kParticleMaxBlockLog2);
  EXPECT_EQ(particleBlockLog2(14.0f, -1.0f), 3u); // 8 texels span 7 of its 14 pixels
  for (float bias : {-2.0f, -0.25f, 0.0f, 1.0f}) {
    EXPECT_EQ(particleBlockLog2(particleCapLength(bias), bias), kParticleMaxBlockLog2) << bias;
    EXPECT_EQ(blockLog2ForLength(particleCapLength(bias), 3, bias), kParticleMaxBlockLog2) << "the cap: " << bias;
    EXPECT_GT(blockLog2ForLength(particleCapLength(bias) * 1.1f, 3, bias), kParticleMaxBlockLog2) << bias;
  }
}

} // namespace mirage::stream
