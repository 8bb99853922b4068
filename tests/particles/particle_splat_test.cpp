// The splat of small particles (docs/particles.md, "Splat"): a cloud of small particles splatted
// looks like the same cloud drawn as billboards through weighted blending (float and fixed-point
// sums alike), the splat conserves coverage (alpha times footprint area, summed over the image),
// particles behind opaque geometry add nothing, and each stereo half is its eye's mono image.
// Validation layers silent (lavapipe).
#include <array>
#include <cmath>
#include <cstdio>
#include <utility>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/color.h"
#include "mirage/core/image_metrics.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/particle_draw.h"
#include "particles/particle_test_util.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kSplatSize = 128;
using test::withAnchor;

} // namespace

class ParticleSplat : public test::GpuTest {};

namespace {

// Pixels across a billboard of edge `size` at view distance `distance`.
float pixelsOf(float size, float distance) {
  return size / (2.0f * distance * std::tan(glm::radians(test::kParticleFov) * 0.5f)) * float(kSplatSize);
}

ForwardRenderSettings splatView(OitMode mode, ParticleDraw* particles, glm::vec4 background) {
  return test::particleView(kSplatSize, mode, particles, background);
}

std::unique_ptr<ParticleDraw> puffDraw(gpu::Context& ctx) {
  // 2 x 2 tiles of 8 x 8 texels, each a soft dot of its own strength (alpha from greyscale).
  ParticleSheet sheet{ImageRGBA8{16, 16, {}}, 2, 2, true};
  for (uint32_t y = 0; y < 16; ++y)
    for (uint32_t x = 0; x < 16; ++x) {
      float r = glm::length(glm::vec2(float(x % 8) - 3.5f, float(y % 8) - 3.5f)) / 4.0f;
      float strength = 0.5f + 0.25f * float((x / 8) + 2 * (y / 8)) / 3.0f;
      uint8_t v = uint8_t(255.0f * strength * std::clamp(1.3f - r, 0.0f, 1.0f));
      sheet.image.pixels.insert(sheet.image.pixels.end(), {v, v, v, 255});
    }
  auto d = ParticleDraw::create(ctx, {&sheet, 1});
  EXPECT_TRUE(d.ok()) << (d.ok() ? "" : d.error().message);
  return d.ok() ? std::move(*d) : nullptr;
}

// An unrotated particle showing tile `frame` of its sheet.
sio::RenderParticle tileParticle(glm::vec3 position, float size, glm::vec4 color, uint32_t frame = 0) {
  return test::particleRecord(position, size, color, 0.0f, frame);
}

// A deterministic cloud of small particles (0.6 to 1.9 pixels across) in front of the camera.
std::vector<sio::RenderParticle> smallCloud(uint32_t count) {
  std::vector<sio::RenderParticle> out;
  for (uint32_t i = 0; i < count; ++i) {
    float t = float(i);
    glm::vec3 p{1.6f * std::sin(t * 1.37f), 1.6f * std::cos(t * 0.91f), 0.8f * std::sin(t * 2.13f)};
    float pixels = 0.6f + 1.3f * (0.5f + 0.5f * std::sin(t * 0.53f));
    float size = pixels / pixelsOf(1.0f, test::kParticleDistance - p.z);
    glm::vec4 color{0.5f + 0.5f * std::sin(t), 0.6f, 0.5f + 0.5f * std::cos(t * 0.7f),
                    0.6f + 0.4f * std::fabs(std::sin(t * 0.3f))};
    out.push_back(tileParticle(p, size, color, i % 4));
  }
  return out;
}

// `img` averaged over factor x factor blocks in linear light, as 8-bit sRGB.
ImageRGBA8 downsample(const ImageF32& img, uint32_t factor) {
  ImageRGBA8 out{img.width / factor, img.height / factor, {}};
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x)
      for (uint32_t c = 0; c < 4; ++c) {
        float sum = 0.0f;
        for (uint32_t k = 0; k < factor * factor; ++k)
          sum += img.pixels[((y * factor + k / factor) * img.width + x * factor + k % factor) * 4 + c];
        out.pixels.push_back(c == 3 ? 255 : linearToSrgb8(sum / float(factor * factor)));
      }
  return out;
}

std::vector<SplatAtomics> atomicsToTest(const gpu::Context& ctx) {
  std::vector<SplatAtomics> list;
  if (ctx.caps().floatBufferAtomicAdd) list.push_back(SplatAtomics::Float);
  if (ctx.caps().int64BufferAtomics) list.push_back(SplatAtomics::Fixed);
  return list;
}

// Small particles over a grey wall: the splat's image against the billboards' (weighted blending,
// the same order-independent approximation). Sub-pixel billboards hit or miss pixel centres (grown
// to 1.5 pixels), where the splat spreads their coverage by area: the splat is compared with the
// billboards drawn at 4 x the resolution and box-filtered (>= 38 dB, the particles 2.4 to 7.6
// pixels wide there), and with those at its own resolution (>= 30 dB; >= 40 dB over 4 x 4 blocks),
// each far closer than the wall alone; the float and fixed-point sums within 50 dB of each other;
// the splat leaves no billboard.
TEST_F(ParticleSplat, MatchesWeightedBillboardsOnSmallParticles) {
  if (atomicsToTest(context()).empty()) GTEST_SKIP() << "no float or 64-bit buffer atomics";
  Scene scene = withAnchor({test::makeQuad(4.0f, -2.0f)}, {test::solidMaterial({0.3f, 0.3f, 0.35f, 1})});
  auto draw = puffDraw(context());
  ASSERT_TRUE(draw);
  std::vector<sio::RenderParticle> cloud = smallCloud(1500);
  test::showParticles(*draw, cloud);
  const glm::vec4 background{0.05f, 0.05f, 0.1f, 1};
  ASSERT_TRUE(draw->setSettings({0.0f, SplatAtomics::Auto}).ok()); // billboards only
  RenderOutput billboards = test::renderForward(context(), scene, splatView(OitMode::Weighted, draw.get(), background));
  ForwardRenderSettings fine = splatView(OitMode::Weighted, draw.get(), background);
  fine.base.width = fine.base.height = 4 * kSplatSize;
  ImageRGBA8 reference = downsample(test::renderForward(context(), scene, fine).linear, 4);
  RenderOutput bare = test::renderForward(context(), scene, splatView(OitMode::Weighted, nullptr, background));
  double signal = psnr(reference, bare.srgb);
  std::vector<ImageRGBA8> splats;
  for (SplatAtomics atomics : atomicsToTest(context())) {
    ASSERT_TRUE(draw->setSettings({kDefaultSplatPixels, atomics}).ok());
    RenderOutput splat = test::renderForward(context(), scene, splatView(OitMode::Weighted, draw.get(), background));
    EXPECT_EQ(draw->readBillboardCount(), 0u) << "every particle is under the threshold";
    double vsReference = psnr(reference, splat.srgb), vsBillboards = psnr(billboards.srgb, splat.srgb);
    double blocks = psnr(downsample(billboards.linear, 4), downsample(splat.linear, 4));
    std::printf("splat (%s) vs 4x billboards %.2f dB (signal %.2f dB), vs billboards %.2f dB (4x4 blocks %.2f dB)\n",
                atomics == SplatAtomics::Float ? "float" : "fixed", vsReference, signal, vsBillboards, blocks);
    EXPECT_GE(vsReference, 38.0);
    EXPECT_GE(vsBillboards, 30.0);
    EXPECT_GE(blocks, 40.0);
    splats.push_back(std::move(splat.srgb));
  }
  EXPECT_LT(signal, 30.0) << "the particles must show";
  if (splats.size() == 2) {
    EXPECT_GE(psnr(splats[0], splats[1]), 50.0) << "float and fixed-point sums";
  }
}

// White particles of alpha 0.6 on black, apart from each other: each pixel's colour is its
// coverage, so the image sums to sum(alpha x footprint area in pixels) (within 0.5 %: the colour
// target is half float), for footprints of 0.5 to 1.9 pixels at any sub-pixel position, in both
// transparency modes the splat serves.
TEST_F(ParticleSplat, ConservesCoverage) {
  if (atomicsToTest(context()).empty()) GTEST_SKIP() << "no float or 64-bit buffer atomics";
  Scene scene = withAnchor({}, {});
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  const float kAlpha = 153.0f / 255.0f; // exact in the record's RGBA8
  std::vector<sio::RenderParticle> grid;
  double expected = 0.0;
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) {
      float pixels = 0.5f + 1.4f * float((x + 3 * y) % 10) / 9.0f;
      float size = pixels / pixelsOf(1.0f, test::kParticleDistance);
      // 10 pixels apart, at sub-pixel offsets that vary with the particle.
      glm::vec2 at = (glm::vec2(float(x), float(y)) * 10.0f + 15.3f + 0.37f * float(x * y % 7)) / float(kSplatSize);
      glm::vec2 world =
          (at * 2.0f - 1.0f) * test::kParticleDistance * std::tan(glm::radians(test::kParticleFov) * 0.5f);
      grid.push_back(tileParticle({world.x, -world.y, 0.0f}, size, {1, 1, 1, kAlpha}));
      expected += double(kAlpha) * pixels * pixels;
    }
  test::showParticles(*draw, grid);
  for (SplatAtomics atomics : atomicsToTest(context())) {
    for (OitMode mode : {OitMode::LinkedList, OitMode::Weighted}) {
      ASSERT_TRUE(draw->setSettings({kDefaultSplatPixels, atomics}).ok());
      RenderOutput out = test::renderForward(context(), scene, splatView(mode, draw.get(), {0, 0, 0, 1}));
      ASSERT_EQ(out.linear.width, kSplatSize);
      double sum = 0.0;
      for (size_t i = 0; i < out.linear.pixels.size(); i += 4) sum += out.linear.pixels[i];
      std::printf("%s %s: coverage %.4f px^2, expected %.4f\n", atomics == SplatAtomics::Float ? "float" : "fixed",
                  toString(mode), sum, expected);
      EXPECT_NEAR(sum, expected, 0.005 * expected);
    }
  }
}

// Small particles behind an opaque quad (z = 1, covering the cloud) change nothing; in front of
// it (z = 2) they show.
TEST_F(ParticleSplat, RespectsTheOpaqueDepth) {
  if (atomicsToTest(context()).empty()) GTEST_SKIP() << "no float or 64-bit buffer atomics";
  Scene scene = withAnchor({test::makeQuad(2.5f, 1.0f)}, {test::solidMaterial({0.2f, 0.7f, 0.3f, 1})});
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  const glm::vec4 background{0.05f, 0.05f, 0.1f, 1};
  RenderOutput bare = test::renderForward(context(), scene, splatView(OitMode::LinkedList, nullptr, background));
  std::vector<sio::RenderParticle> cloud = smallCloud(600);
  for (sio::RenderParticle& p : cloud) { // all behind the quad, opaque white, under 2 pixels
    p.position.z = 0.0f;
    p.size *= 0.85f;
    p.color = sio::particlePackColor({1, 1, 1, 1});
  }
  test::showParticles(*draw, cloud);
  RenderOutput behind = test::renderForward(context(), scene, splatView(OitMode::LinkedList, draw.get(), background));
  EXPECT_EQ(draw->readBillboardCount(), 0u);
  EXPECT_GE(psnr(bare.srgb, behind.srgb), 60.0);
  for (sio::RenderParticle& p : cloud) p.position.z = 2.0f, p.size *= 0.6f; // in front, as small
  test::showParticles(*draw, cloud);
  RenderOutput front = test::renderForward(context(), scene, splatView(OitMode::LinkedList, draw.get(), background));
  EXPECT_EQ(draw->readBillboardCount(), 0u);
  EXPECT_LT(psnr(bare.srgb, front.srgb), 30.0);
}

// The binned splat (screen tiles, shared-memory sums) against the splat by global atomics per
// pixel: the same image up to float summation order (>= 50 dB, 8-bit sRGB), for float and
// fixed-point sums, on a cloud with a hot pixel (4000 particles on one spot at the image centre,
// a corner of four 16-pixel tiles, so each of those tiles lists more than one chunk of entries),
// another on one pixel inside a tile, and particles straddling tile borders; with a room that lists
// every entry, the default room and a room of 300 entries (the rest added directly by global
// atomics), and with a table of 4 slots in the count and scatter passes (most tiles counted and
// placed by global atomics per entry, beside the few the table holds), in mono and stereo. Every
// particle is splatted and the hot spot shows.
TEST_F(ParticleSplat, BinnedEqualsAtomicSplat) {
  if (atomicsToTest(context()).empty()) GTEST_SKIP() << "no float or 64-bit buffer atomics";
  Scene scene = withAnchor({test::makeQuad(4.0f, -2.0f)}, {test::solidMaterial({0.3f, 0.3f, 0.35f, 1})});
  auto draw = puffDraw(context());
  ASSERT_TRUE(draw);
  // World position of image pixel coordinate `at` (pixels from the top left) at z = 0.
  auto worldAt = [](glm::vec2 at) {
    glm::vec2 w = (at / float(kSplatSize) * 2.0f - 1.0f) * test::kParticleDistance *
                  std::tan(glm::radians(test::kParticleFov) * 0.5f);
    return glm::vec3(w.x, -w.y, 0.0f);
  };
  std::vector<sio::RenderParticle> cloud = smallCloud(1500);
  const float onePixel = 1.0f / pixelsOf(1.0f, test::kParticleDistance);
  for (uint32_t i = 0; i < 4000; ++i) // the hot spot: on the corner of four tiles
    cloud.push_back(tileParticle(worldAt(glm::vec2(64.0f)), (1.0f + 0.8f * float(i % 5) / 4.0f) * onePixel,
                                 {0.9f, 0.5f + 0.1f * float(i % 4), 0.2f, 0.05f + 0.1f * float(i % 3)}, i % 4));
  for (uint32_t i = 0; i < 500; ++i) // inside one pixel of one tile
    cloud.push_back(tileParticle(worldAt(glm::vec2(40.5f)), 0.7f * onePixel, {0.2f, 0.9f, 0.4f, 0.3f}, i % 4));
  for (uint32_t i = 0; i < 400; ++i) { // along the borders x = 32 and y = 96, at sub-pixel offsets
    float along = 4.0f + 0.3f * float(i);
    float off = 0.25f * float(i % 7) - 0.75f;
    glm::vec2 at = i % 2 ? glm::vec2(32.0f + off, along) : glm::vec2(along, 96.0f + off);
    cloud.push_back(tileParticle(worldAt(at), (0.8f + 0.15f * float(i % 8)) * onePixel,
                                 {0.3f, 0.4f, 0.95f, 0.5f + 0.05f * float(i % 9)}, i % 4));
  }
  test::showParticles(*draw, cloud);
  const glm::vec4 background{0.05f, 0.05f, 0.1f, 1};
  RenderOutput bare = test::renderForward(context(), scene, splatView(OitMode::LinkedList, nullptr, background));
  for (SplatAtomics atomics : atomicsToTest(context())) {
    const char* name = atomics == SplatAtomics::Float ? "float" : "fixed";
    for (bool stereo : {false, true}) {
      ForwardRenderSettings s = splatView(OitMode::LinkedList, draw.get(), background);
      if (stereo) s.stereoIpd = 0.3f;
      ASSERT_TRUE(draw->setSettings({kDefaultSplatPixels, atomics, SplatMethod::Atomic}).ok());
      RenderOutput atomic = test::renderForward(context(), scene, s);
      EXPECT_EQ(draw->readBillboardCount(), 0u);
      if (!stereo) {
        EXPECT_LT(psnr(bare.srgb, atomic.srgb), 30.0) << "the particles must show";
        size_t hot = (64 * kSplatSize + 64) * 4;
        EXPECT_GT(std::abs(int(atomic.srgb.pixels[hot]) - int(bare.srgb.pixels[hot])), 40) << "the hot spot shows";
      }
      for (auto [room, slots] : {std::pair{100000u, 0u}, {0u, 0u}, {300u, 0u}, {0u, 4u}, {300u, 4u}}) {
        ASSERT_TRUE(draw->setSettings({kDefaultSplatPixels, atomics, SplatMethod::Binned, room, slots}).ok());
        EXPECT_TRUE(draw->splatsBinned());
        RenderOutput binned = test::renderForward(context(), scene, s);
        EXPECT_EQ(draw->readBillboardCount(), 0u);
        double p = psnr(atomic.srgb, binned.srgb);
        std::printf("%s%s, room %u, slots %u: binned vs atomic splat %.2f dB\n", name, stereo ? " stereo" : "", room,
                    slots, p);
        EXPECT_GE(p, 50.0) << name << (stereo ? " stereo" : "") << " room " << room << " slots " << slots;
      }
    }
  }
}

// Stereo: each half of the side-by-side image is the mono image of its eye (stereoEyes), the
// splat writing each eye's footprints into its half against its half of the depth.
TEST_F(ParticleSplat, StereoHalvesAreTheEyesMonoImages) {
  if (atomicsToTest(context()).empty()) GTEST_SKIP() << "no float or 64-bit buffer atomics";
  Scene scene = withAnchor({test::makeQuad(0.8f, 1.0f), test::makeQuad(4.0f, -2.0f, 1)},
                           {test::solidMaterial({0.2f, 0.7f, 0.3f, 1}), test::solidMaterial({0.3f, 0.3f, 0.35f, 1})});
  auto draw = puffDraw(context());
  ASSERT_TRUE(draw);
  std::vector<sio::RenderParticle> cloud = smallCloud(800);
  test::showParticles(*draw, cloud);
  const glm::vec4 background{0.05f, 0.05f, 0.1f, 1};
  ForwardRenderSettings stereo = splatView(OitMode::LinkedList, draw.get(), background);
  stereo.stereoIpd = 0.4f;
  RenderOutput both = test::renderForward(context(), scene, stereo);
  EXPECT_EQ(draw->readBillboardCount(), 0u);
  ASSERT_EQ(both.srgb.width, 2 * kSplatSize);
  std::array<Camera, 2> eyes = stereoEyes(stereo.base.camera, *stereo.stereoIpd);
  for (uint32_t e = 0; e < 2; ++e) {
    ForwardRenderSettings mono = splatView(OitMode::LinkedList, draw.get(), background);
    mono.base.camera = eyes[e];
    RenderOutput one = test::renderForward(context(), scene, mono);
    ImageRGBA8 half{kSplatSize, kSplatSize, {}};
    for (uint32_t y = 0; y < kSplatSize; ++y)
      half.pixels.insert(half.pixels.end(), both.srgb.pixels.begin() + (y * 2 * kSplatSize + e * kSplatSize) * 4,
                         both.srgb.pixels.begin() + (y * 2 * kSplatSize + (e + 1) * kSplatSize) * 4);
    double p = psnr(one.srgb, half);
    std::printf("eye %u: stereo half vs mono %.2f dB\n", e, p);
    EXPECT_GE(p, 50.0) << "eye " << e;
  }
}

} // namespace
