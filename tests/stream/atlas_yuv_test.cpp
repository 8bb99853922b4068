// The atlas's YUV conversion on the GPU (AtlasShading::convertAtlasYuv, atlas_yuv.comp) against the
// H.264 encoder's CPU path (libswscale, stream::rgbaToI420) on a shaded atlas of noise: every sample
// within 1; with stacked alpha the lower half is the alpha as luma exactly and no chroma. Validation
// must stay silent.
#include <algorithm>
#include <cstdlib>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/stream/video.h"
#include "test_scenes.h"

namespace mirage {
namespace {

using shaderio::GpuAtlasPatch;

// A quad whose colour and alpha are noise: a random texture as the emission and the base colour
// (its alpha: BLEND), on a black Blinn-Phong base so the texture shows almost as it is.
Scene noiseQuadScene() {
  constexpr uint32_t kSide = 64;
  Texture noise{"noise", kSide, kSide, std::vector<uint8_t>(kSide * kSide * 4), true};
  std::mt19937 rng(7);
  for (uint8_t& byte : noise.rgba8) byte = uint8_t(rng());
  Material m = test::solidMaterial({0, 0, 0, 1}, AlphaMode::Blend);
  m.model = ShadingModel::BlinnPhong;
  m.specularColor = glm::vec3(0.0f);
  m.baseColorTexture = 0;
  m.emissiveTexture = 0;
  m.emissiveFactor = glm::vec3(1.0f);
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {m});
  scene.textures.push_back(std::move(noise));
  return scene;
}

// The atlas, 256 texels, with a 128-texel block of noise, a 64-texel one and a 2-texel one (the
// smallest: one chroma quad), the rest zero.
std::unique_ptr<render::AtlasShading> shadedNoiseAtlas(gpu::Context& ctx) {
  Scene scene = noiseQuadScene();
  auto atlas = render::AtlasShading::create(ctx, scene, {0, 0}, {256, 64});
  EXPECT_TRUE(atlas.ok()) << (atlas.ok() ? "" : atlas.error().message);
  if (!atlas) return nullptr;
  std::vector<GpuAtlasPatch> patches;
  for (auto [x, y, log2] : {std::array<uint32_t, 3>{0, 0, 7}, {128, 128, 6}, {200, 40, 1}}) {
    GpuAtlasPatch p{};
    p.vertices[MIRAGE_PATCH_A] = 0;
    p.vertices[MIRAGE_PATCH_B] = 1;
    p.vertices[MIRAGE_PATCH_C] = 3;
    p.vertices[MIRAGE_PATCH_D] = 2;
    p.triangleCount = 2;
    p.blockX = x;
    p.blockY = y;
    p.blockLog2 = log2;
    patches.push_back(p);
  }
  EXPECT_TRUE((*atlas)->shade(patches, {}, {0, 0, 4}).ok());
  return std::move(*atlas);
}

// The image the encoder took before the GPU converted: the colour, and with stacked alpha the alpha
// below it as grey (what the JPEG path still stacks on the CPU).
std::vector<uint8_t> stackedRgba(const ImageRGBA8& atlas, bool stackedAlpha) {
  std::vector<uint8_t> out = atlas.pixels;
  if (!stackedAlpha) return out;
  for (size_t i = 0; i < atlas.pixels.size(); i += 4) {
    uint8_t a = atlas.pixels[i + 3];
    out.insert(out.end(), {a, a, a, 255});
  }
  return out;
}

class AtlasYuv : public test::GpuTest {
protected:
  void expectMatchesSwscale(bool stackedAlpha) {
    auto atlas = shadedNoiseAtlas(context());
    ASSERT_TRUE(atlas);
    render::AtlasYuvImage yuv = atlas->createYuvImage(stackedAlpha);
    ASSERT_EQ(yuv.height(), stackedAlpha ? 512u : 256u);
    ASSERT_TRUE(atlas->convertAtlasYuv(yuv).ok());
    ImageRGBA8 rgba = atlas->readAtlas();
    auto reference = stream::rgbaToI420(stackedRgba(rgba, stackedAlpha), 256, yuv.height());
    ASSERT_TRUE(reference.ok()) << reference.error().message;
    std::span<const uint8_t> gpu = yuv.i420();
    ASSERT_EQ(gpu.size(), reference->size());

    const size_t luma = size_t(256) * yuv.height(), chroma = luma / 4;
    int worst[3] = {0, 0, 0};
    size_t off = 0;
    for (size_t i = 0; i < gpu.size(); ++i) {
      int plane = i < luma ? 0 : i < luma + chroma ? 1 : 2;
      int d = std::abs(int(gpu[i]) - int((*reference)[i]));
      worst[plane] = std::max(worst[plane], d);
      off += d != 0;
    }
    EXPECT_LE(worst[0], 1) << "Y";
    EXPECT_LE(worst[1], 1) << "U";
    EXPECT_LE(worst[2], 1) << "V";
    std::printf("stacked alpha %d: worst Y %d U %d V %d, %zu of %zu samples off by 1\n", int(stackedAlpha), worst[0],
                worst[1], worst[2], off, gpu.size());

    // The atlas is noise where shaded (the comparison means something), and zero elsewhere.
    std::set<uint8_t> lumaValues(gpu.begin(), gpu.begin() + 128 * 256);
    EXPECT_GT(lumaValues.size(), 100u);
    EXPECT_EQ(gpu[255], 0) << "an unshaded texel";
    if (!stackedAlpha) return;
    // Below the colour: luma is the alpha exactly, chroma grey.
    std::set<uint8_t> alphaValues;
    for (uint32_t y = 0; y < 256; ++y)
      for (uint32_t x = 0; x < 256; ++x) {
        ASSERT_EQ(gpu[(256 + y) * 256 + x], rgba.at(x, y)[3]) << x << "," << y;
        alphaValues.insert(rgba.at(x, y)[3]);
      }
    EXPECT_GT(alphaValues.size(), 100u) << "the alpha is noise too";
    for (size_t i = luma + chroma / 2; i < luma + chroma; ++i) ASSERT_EQ(gpu[i], 128) << "U below, byte " << i;
    for (size_t i = luma + chroma + chroma / 2; i < gpu.size(); ++i) ASSERT_EQ(gpu[i], 128) << "V below, byte " << i;
  }
};

TEST_F(AtlasYuv, ColourMatchesSwscaleWithinOne) { expectMatchesSwscale(/*stackedAlpha=*/false); }

TEST_F(AtlasYuv, StackedAlphaMatchesSwscaleWithinOne) { expectMatchesSwscale(/*stackedAlpha=*/true); }

TEST_F(AtlasYuv, ImageOfAnotherAtlasIsAnError) {
  Scene scene = noiseQuadScene();
  auto small = render::AtlasShading::create(context(), scene, {0, 0}, {128, 64});
  auto large = render::AtlasShading::create(context(), scene, {0, 0}, {256, 64});
  ASSERT_TRUE(small.ok() && large.ok());
  render::AtlasYuvImage image = (*small)->createYuvImage(false);
  EXPECT_FALSE((*large)->convertAtlasYuv(image).ok());
  render::AtlasYuvImage empty;
  EXPECT_FALSE((*small)->convertAtlasYuv(empty).ok());
}

} // namespace
} // namespace mirage
