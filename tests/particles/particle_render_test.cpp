// Particle billboards in the forward renderer (docs/particles.md, "Rendering"): a single particle's
// screen footprint and colour against the projection, occlusion by opaque geometry, particles and
// transparent geometry interleaved in depth against the composite in depth order (linked lists and
// the sorted reference), CPU- and GPU-simulated effects giving the same image. Validation layers
// silent (lavapipe, small images).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/particles/render.h"
#include "mirage/render/forward_renderer.h"
#include "particles/particle_test_util.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kRenderSize = 64;
const glm::vec4 kBackground{0.05f, 0.1f, 0.2f, 1.0f};
using test::withAnchor;

} // namespace

class ParticleRender : public test::GpuTest {};

namespace {

// Pixels from the centre to a billboard edge of `size` world units at the view distance.
float halfExtentPixels(float size) {
  return 0.5f * size / (test::kParticleDistance * std::tan(glm::radians(test::kParticleFov) * 0.5f)) *
         (0.5f * float(kRenderSize));
}

ForwardRenderSettings renderView(OitMode mode, ParticleDraw* particles) {
  return test::particleView(kRenderSize, mode, particles, kBackground);
}

ImageF32 renderLinear(gpu::Context& ctx, const Scene& scene, const ForwardRenderSettings& s) {
  return test::renderForward(ctx, scene, s).linear;
}

// `system` as an effect of its own, simulated `steps` steps of 1/60 s; more than 50 particles live.
std::unique_ptr<particles::EffectPlayer> play(gpu::Context& ctx, const particles::SystemDef& system,
                                              particles::SimKind sim, uint32_t steps) {
  auto player = particles::EffectPlayer::create(ctx, {system.name + ".toml", {system}}, sim, test::kStepSeconds);
  EXPECT_TRUE(player.ok()) << (player.ok() ? "" : player.error().message);
  if (!player.ok()) return nullptr;
  (*player)->step(steps);
  EXPECT_GT((*player)->live(), 50u);
  return std::move(*player);
}

void expectNear(glm::vec3 got, glm::vec3 want, float tolerance, const char* what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], tolerance) << what << " channel " << c;
}

// A square of edge size at the centre: covered within its projected half extent, background
// beyond; its colour blended "over" the background with its alpha. Every mode, as one layer is
// exact in each. Turned 45 degrees it is a diamond: a pixel inside the square's corner is empty.
TEST_F(ParticleRender, SingleParticleFootprintAndColour) {
  Scene scene = withAnchor({}, {});
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  const glm::vec4 color{0.8f, 0.4f, 0.2f, 0.6f};
  float half = halfExtentPixels(1.0f); // 7.7 px
  glm::vec3 expected = glm::mix(glm::vec3(kBackground), glm::vec3(color), color.a);
  for (OitMode mode : {OitMode::LinkedList, OitMode::Weighted, OitMode::Sorted}) {
    SCOPED_TRACE(toString(mode));
    sio::RenderParticle p = test::particleRecord({0, 0, 0}, 1.0f, color);
    test::showParticles(*draw, {&p, 1});
    ImageF32 img = renderLinear(context(), scene, renderView(mode, draw.get()));
    ASSERT_EQ(img.width, kRenderSize);
    uint32_t c = kRenderSize / 2;
    uint32_t inside = uint32_t(std::floor(half)) - 1, outside = uint32_t(std::ceil(half)) + 1;
    for (auto [dx, dy] :
         {std::pair{0, 0}, {int(inside), 0}, {-int(inside), 0}, {0, int(inside)}, {0, -int(inside) - 1}})
      expectNear(test::linearRgbAt(img, c + dx, c + dy), expected, 4e-3f, "inside");
    for (auto [dx, dy] :
         {std::pair{int(outside), 0}, {-int(outside) - 1, 0}, {0, int(outside)}, {0, -int(outside) - 1}})
      expectNear(test::linearRgbAt(img, c + dx, c + dy), glm::vec3(kBackground), 1e-3f, "outside");
    // Turned: the square's corner region is empty, its edge midpoints' direction reaches further.
    p = test::particleRecord({0, 0, 0}, 1.0f, color, glm::radians(45.0f));
    test::showParticles(*draw, {&p, 1});
    img = renderLinear(context(), scene, renderView(mode, draw.get()));
    uint32_t corner = uint32_t(half * 0.85f);
    expectNear(test::linearRgbAt(img, c + corner, c + corner), glm::vec3(kBackground), 1e-3f, "rotated corner");
    expectNear(test::linearRgbAt(img, c + uint32_t(half * 1.2f), c), expected, 4e-3f, "rotated tip");
  }
}

// A particle a fraction of a pixel wide is grown to 1.5 pixels with its alpha scaled down: the
// image holds about its true coverage (area x alpha) instead of nothing (it hits no pixel centre).
TEST_F(ParticleRender, SubPixelParticlesKeepTheirCoverage) {
  Scene scene = withAnchor({}, {});
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  const glm::vec4 color{1.0f, 1.0f, 1.0f, 1.0f};
  ASSERT_TRUE(draw->setSettings({0.0f}).ok()); // billboards only: the grow rule (the splat: particle_splat_test)
  float side = 2.0f * halfExtentPixels(0.04f); // 0.6 px
  sio::RenderParticle p = test::particleRecord({0, 0, 0}, 0.04f, color);
  test::showParticles(*draw, {&p, 1});
  ImageF32 img = renderLinear(context(), scene, renderView(OitMode::LinkedList, draw.get()));
  ASSERT_EQ(img.width, kRenderSize);
  double coverage = 0.0; // in pixels: each pixel's share of the colour over the background
  for (uint32_t y = 0; y < kRenderSize; ++y)
    for (uint32_t x = 0; x < kRenderSize; ++x)
      coverage += (test::linearRgbAt(img, x, y).r - kBackground.r) / (1.0f - kBackground.r);
  double area = double(side) * side;
  // The grown square covers 1 to 4 pixel centres for its 2.25 pixels of area.
  EXPECT_GT(coverage, 0.4 * area);
  EXPECT_LT(coverage, 2.0 * area);
}

// An opaque quad at z = 1 over the centre: a particle at z = 0 is hidden there (the image equals
// the one without particles) and seen around it; at z = 2 it covers the quad too.
TEST_F(ParticleRender, OpaqueGeometryOccludes) {
  Scene scene = withAnchor({test::makeQuad(0.3f, 1.0f)}, {test::solidMaterial({0.2f, 0.9f, 0.2f, 1})});
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  draw->setCpuBatches({});
  ImageF32 bare = renderLinear(context(), scene, renderView(OitMode::LinkedList, draw.get()));
  const glm::vec4 color{1.0f, 0.1f, 0.1f, 0.7f};
  uint32_t c = kRenderSize / 2, side = c + uint32_t(halfExtentPixels(1.6f) * 0.8f);
  for (OitMode mode : {OitMode::LinkedList, OitMode::Weighted}) {
    SCOPED_TRACE(toString(mode));
    sio::RenderParticle p = test::particleRecord({0, 0, 0}, 2.0f, color);
    test::showParticles(*draw, {&p, 1});
    ImageF32 behind = renderLinear(context(), scene, renderView(mode, draw.get()));
    expectNear(test::linearRgbAt(behind, c, c), test::linearRgbAt(bare, c, c), 1e-3f, "behind the quad");
    expectNear(test::linearRgbAt(behind, side, c), glm::mix(glm::vec3(kBackground), glm::vec3(color), color.a), 4e-3f,
               "beside");
    p.position.z = 2.0f;
    test::showParticles(*draw, {&p, 1});
    ImageF32 front = renderLinear(context(), scene, renderView(mode, draw.get()));
    expectNear(test::linearRgbAt(front, c, c), glm::mix(test::linearRgbAt(bare, c, c), glm::vec3(color), color.a),
               4e-3f, "in front");
  }
}

// Transparent quads at z = -0.5 (A) and z = 0.5 (B), a particle between them: the linked lists
// sort it between them, so the pixel is B over particle over A over the background, each layer
// measured alone over black (its premultiplied colour). Drawing the particle last (nearest)
// gives another colour, which the test tells apart.
TEST_F(ParticleRender, InterleavesWithTransparentGeometry) {
  Material a = test::solidMaterial({0.9f, 0.2f, 0.1f, 0.5f}, AlphaMode::Blend, true);
  Material b = test::solidMaterial({0.1f, 0.3f, 0.9f, 0.4f}, AlphaMode::Blend, true);
  auto draw = test::whiteParticleDraw(context());
  ASSERT_TRUE(draw);
  const glm::vec4 color{0.2f, 0.9f, 0.3f, 0.6f};
  sio::RenderParticle p = test::particleRecord({0, 0, 0}, 1.0f, color);
  draw->setCpuBatches({});
  ForwardRenderSettings black = renderView(OitMode::LinkedList, draw.get());
  black.base.background = {0, 0, 0, 1};
  uint32_t c = kRenderSize / 2;
  glm::vec3 aPre =
      test::linearRgbAt(renderLinear(context(), withAnchor({test::makeQuad(1.0f, -0.5f)}, {a}), black), c, c);
  glm::vec3 bPre =
      test::linearRgbAt(renderLinear(context(), withAnchor({test::makeQuad(1.0f, 0.5f)}, {b}), black), c, c);
  glm::vec3 bg(kBackground);
  glm::vec3 behindA = aPre + (1.0f - 0.5f) * bg;
  glm::vec3 withP = glm::vec3(color) * color.a + (1.0f - color.a) * behindA;
  glm::vec3 expected = bPre + (1.0f - 0.4f) * withP;
  glm::vec3 particleLast = glm::mix(bPre + (1.0f - 0.4f) * behindA, glm::vec3(color), color.a);
  ASSERT_GT(glm::length(expected - particleLast), 0.05f) << "the test cannot tell the orders apart";

  test::showParticles(*draw, {&p, 1});
  Scene both = withAnchor({test::makeQuad(1.0f, -0.5f, 0), test::makeQuad(1.0f, 0.5f, 1)}, {a, b});
  ImageF32 img = renderLinear(context(), both, renderView(OitMode::LinkedList, draw.get()));
  for (auto [dx, dy] : {std::pair{0, 0}, {3, 2}, {-4, -3}})
    expectNear(test::linearRgbAt(img, c + dx, c + dy), expected, 5e-3f, "lists");
  // The sorted reference sorts the particle between the quads' triangles (B's in front of it).
  ImageF32 sorted = renderLinear(context(), both, renderView(OitMode::Sorted, draw.get()));
  for (auto [dx, dy] : {std::pair{0, 0}, {3, 2}, {-4, -3}})
    expectNear(test::linearRgbAt(sorted, c + dx, c + dy), expected, 5e-3f, "sorted");
  // Weighted blending approximates the order: within its error on three layers.
  ImageF32 weighted = renderLinear(context(), both, renderView(OitMode::Weighted, draw.get()));
  expectNear(test::linearRgbAt(weighted, c, c), expected, 0.15f, "weighted");
}

// A GPU-simulated cloud of overlapping particles around a glass quad, in front of and behind it:
// the sorted reference (particles sorted on the GPU by view depth, drawn between the sorted glass
// triangles) and the linked lists (sorted per pixel) agree; billboards lie in view planes, so the
// orders differ only where one cuts through the glass.
TEST_F(ParticleRender, SortedAgreesWithLinkedListsAroundGlass) {
  particles::SystemDef s;
  s.name = "cloud";
  s.startLifetime = {2.0f, 3.0f};
  s.startSpeed = {0.3f, 0.8f};
  s.startSize = {0.3f, 0.6f};
  s.startColor = {{0.9f, 0.3f, 0.1f, 0.5f}, {0.2f, 0.6f, 1.0f, 0.9f}};
  s.maxParticles = 200;
  s.rateOverTime = 150.0f;
  Material glass = test::solidMaterial({0.9f, 0.9f, 0.2f, 0.5f}, AlphaMode::Blend, true);
  Scene scene = withAnchor({test::makeQuad(0.6f, 0.0f, 0), test::makeQuad(3.0f, -2.0f, 1)},
                           {glass, test::solidMaterial({0.4f, 0.4f, 0.4f, 1})});
  auto player = play(context(), s, particles::SimKind::Gpu, 60);
  ASSERT_TRUE(player);
  ForwardRenderSettings fs = renderView(OitMode::LinkedList, player->draw());
  fs.base.camera.eye = {0.3f, 0.5f, 4.0f};
  auto renderer = ForwardRenderer::create(context(), scene);
  ASSERT_TRUE(renderer.ok());
  auto lists = (*renderer)->render(fs);
  fs.oit = OitMode::Sorted;
  auto sorted = (*renderer)->render(fs);
  fs.particles = nullptr;
  auto bare = (*renderer)->render(fs);
  ASSERT_TRUE(lists.ok() && sorted.ok() && bare.ok());
  double p = psnr(lists->srgb, sorted->srgb);
  std::printf("sorted vs linked lists: %.2f dB (vs no particles %.2f)\n", p, psnr(lists->srgb, bare->srgb));
  EXPECT_GE(p, 40.0);
  EXPECT_LT(psnr(lists->srgb, bare->srgb), 30.0);
}

// One effect simulated on the CPU and on the GPU: the same particles (to float precision), so
// the same image (PSNR over the 8-bit result).
TEST_F(ParticleRender, CpuAndGpuSimulationsRenderAlike) {
  particles::SystemDef s;
  s.name = "burst";
  s.startLifetime = {1.0f, 2.0f};
  s.startSpeed = {0.5f, 1.5f};
  s.startSize = {0.2f, 0.4f};
  s.startColor = {{0.9f, 0.5f, 0.1f, 0.5f}, {1.0f, 0.9f, 0.3f, 0.9f}};
  s.gravityModifier = 0.1f;
  s.maxParticles = 300;
  s.rateOverTime = 200.0f;
  s.sheet.texture = "puff";
  s.sheet.tilesX = s.sheet.tilesY = 2;
  s.sheet.alphaFromGreyscale = true;
  Scene scene = withAnchor({test::makeQuad(3.0f, -2.0f)}, {test::solidMaterial({0.4f, 0.4f, 0.4f, 1})});
  auto renderer = ForwardRenderer::create(context(), scene);
  ASSERT_TRUE(renderer.ok());
  ImageRGBA8 images[2];
  for (particles::SimKind sim : {particles::SimKind::Cpu, particles::SimKind::Gpu}) {
    auto player = play(context(), s, sim, 40);
    ASSERT_TRUE(player);
    ForwardRenderSettings fs = renderView(OitMode::LinkedList, player->draw());
    fs.base.camera.eye = {0, 0.5f, 4.0f};
    auto out = (*renderer)->render(fs);
    ASSERT_TRUE(out.ok()) << out.error().message;
    images[sim == particles::SimKind::Gpu] = std::move(out->srgb);
  }
  EXPECT_GE(psnr(images[0], images[1]), 40.0);
  // Not trivially equal: the particles are there (differs from the bare scene).
  auto bare = (*renderer)->render(renderView(OitMode::LinkedList, nullptr));
  ASSERT_TRUE(bare.ok());
  EXPECT_LT(psnr(images[0], bare->srgb), 35.0);
}

} // namespace
