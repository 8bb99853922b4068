// Particle billboards in the cluster-LOD renderer (docs/render.md, "Particles"): the same particles
// over the same scene give the forward renderer's image on every raster backend (mono, stereo by
// viewports and by multiview);
// a particle behind opaque geometry leaves the image unchanged; a particle and a blended panel
// blend in depth order whichever is in front, as "over" of the measured layers predicts.
// Validation layers silent (lavapipe, small images).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/particle_draw.h"
#include "particles/particle_test_util.h"
#include "render/cluster_test_util.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kParticleViewSize = 128;
const glm::vec4 kParticleViewBackground{0.05f, 0.05f, 0.1f, 1.0f};

} // namespace

class ClusterParticles : public test::GpuTest {};

namespace {

// An opaque wall (z = -1) and, unless `glass` is false, a blended panel (z = 0.5) in front of
// its left half.
Scene wallScene(bool glass) {
  std::vector<Mesh> meshes{test::makeGrid(2.5f, -1.0f, 0)};
  std::vector<Material> materials{test::solidMaterial({0.25f, 0.6f, 0.3f, 1.0f}),
                                  test::solidMaterial({0.9f, 0.8f, 0.1f, 0.4f}, AlphaMode::Blend, true)};
  if (glass) meshes.push_back(test::makeGrid(0.8f, 0.5f, 1));
  Scene s = test::makeScene(std::move(meshes), std::move(materials));
  if (glass) s.instances[1].transform = glm::translate(glm::mat4(1.0f), {-0.5f, 0.0f, 0.0f});
  return s;
}

RenderSettings base() {
  RenderSettings s;
  s.width = s.height = kParticleViewSize;
  s.camera.eye = {0.3f, 0.4f, 6.0f};
  s.camera.target = {0.0f, 0.0f, 0.0f};
  s.camera.fovYDegrees = 45.0f;
  s.camera.znear = 0.5f; // both renderers with the same clip planes (the same depth values)
  s.camera.zfar = 20.0f;
  s.background = kParticleViewBackground;
  s.readLinear = true;
  return s;
}

ClusterRenderSettings particleClusterSettings(RasterBackend raster, ParticleDraw* particles) {
  ClusterRenderSettings s;
  s.base = base();
  s.tauPixels = 0.5f;
  s.raster = raster;
  s.particles = particles;
  return s;
}

// A soft round sprite (coverage falling off from the centre): the texture path of both renderers.
std::unique_ptr<ParticleDraw> spriteDraw(gpu::Context& ctx) {
  ParticleSheet sheet{ImageRGBA8{16, 16, {}}, 1, 1, true};
  for (uint32_t y = 0; y < 16; ++y)
    for (uint32_t x = 0; x < 16; ++x) {
      float r = glm::length(glm::vec2(float(x) - 7.5f, float(y) - 7.5f)) / 8.0f;
      uint8_t v = uint8_t(255.0f * std::clamp(1.2f - r, 0.0f, 1.0f));
      sheet.image.pixels.insert(sheet.image.pixels.end(), {v, v, v, 255});
    }
  auto d = ParticleDraw::create(ctx, {&sheet, 1});
  EXPECT_TRUE(d.ok()) << (d.ok() ? "" : d.error().message);
  return d.ok() ? std::move(*d) : nullptr;
}

// Particles before, between and behind the scene's layers, some overlapping each other, some under
// two pixels (splatted).
std::vector<sio::RenderParticle> cloud() {
  std::vector<sio::RenderParticle> p{test::particleRecord({-0.4f, 0.1f, 0.0f}, 1.2f, {1.0f, 0.2f, 0.1f, 0.8f}),
                                     test::particleRecord({0.5f, 0.3f, 1.0f}, 0.9f, {0.2f, 0.4f, 1.0f, 0.7f}, 0.3f),
                                     test::particleRecord({0.2f, -0.4f, 0.8f}, 1.0f, {0.9f, 0.9f, 0.9f, 0.5f}, 1.1f),
                                     test::particleRecord({-0.8f, -0.5f, -1.6f}, 1.0f, {1.0f, 1.0f, 0.0f, 1.0f})};
  for (int i = 0; i < 24; ++i) { // small ones around the panel, in front of and behind it
    float t = float(i) * 0.7f;
    p.push_back(test::particleRecord({1.2f * std::sin(t), 0.9f * std::cos(1.3f * t), 0.9f * std::sin(2.1f * t)},
                                     0.15f + 0.02f * float(i % 5), {0.5f + 0.02f * float(i), 0.8f, 0.3f, 0.6f}));
  }
  for (int i = 0; i < 40; ++i) { // and tiny ones, splatted by default (ParticleDrawSettings)
    float t = float(i) * 1.3f;
    p.push_back(test::particleRecord({1.4f * std::sin(t), 1.0f * std::cos(0.7f * t), 1.2f * std::sin(1.7f * t)},
                                     0.02f + 0.001f * float(i), {1.0f, 0.8f, 0.4f, 0.9f}));
  }
  return p;
}

// Where world point p lands in the image (pixel column, row).
glm::uvec2 pixelOf(glm::vec3 p) {
  Camera c = base().camera;
  glm::vec4 clip = c.projection(1.0f) * c.view() * glm::vec4(p, 1.0f);
  glm::vec2 ndc = glm::vec2(clip) / clip.w;
  return glm::uvec2((ndc * 0.5f + 0.5f) * float(kParticleViewSize));
}

// Every backend, mono and stereo: the forward renderer's image of the same meshes (level 0 of the
// baked asset) and particles, which sorts them with the glass per pixel too; far from the image
// without particles.
TEST_F(ClusterParticles, MatchForwardOnEveryBackend) {
  lod::LodAsset asset = test::bakeScene(wallScene(true));
  ASSERT_FALSE(asset.dags.empty());
  Scene reference = lod::levelZeroScene(asset);
  auto draw = spriteDraw(context());
  ASSERT_TRUE(draw);
  std::vector<sio::RenderParticle> records = cloud();
  ParticleDraw::CpuBatch batch{records, 0};
  draw->setCpuBatches({&batch, 1});
  for (bool stereo : {false, true}) {
    SCOPED_TRACE(stereo ? "stereo" : "mono");
    ForwardRenderSettings fs{base(), {}, OitMode::LinkedList, 8, draw.get()};
    if (stereo) fs.stereoIpd = 0.3f;
    ImageRGBA8 fwd = test::renderForward(context(), reference, fs).srgb;
    fs.particles = nullptr;
    double bare = psnr(fwd, test::renderForward(context(), reference, fs).srgb);
    EXPECT_LT(bare, 30.0) << "the particles must show";
    const gpu::DeviceCapabilities& caps = context().caps();
    for (RasterBackend b : test::availableRasterBackends(context()))
      for (StereoMode mode : {StereoMode::Viewports, StereoMode::Multiview}) {
        // Multiview: the image backends' layered targets (their depth copied side by side).
        bool multiview = mode == StereoMode::Multiview;
        if (multiview && (!stereo || !caps.multiview || b == RasterBackend::Compute || b == RasterBackend::Hybrid ||
                          (b == RasterBackend::Mesh && !caps.multiviewMeshShader)))
          continue;
        ClusterRenderSettings s = particleClusterSettings(b, draw.get());
        if (stereo) s.stereoIpd = 0.3f;
        s.stereoMode = mode;
        ClusterRenderOutput out = test::renderCluster(context(), asset, s);
        double p = psnr(fwd, out.image.srgb);
        std::printf("%s %s%s: %u list fragments, PSNR vs forward %.2f dB (without particles %.2f)\n", toString(b),
                    stereo ? "stereo" : "mono", multiview ? " multiview" : "", out.stats.oitFragments, p, bare);
        EXPECT_GE(p, 40.0) << toString(b) << (multiview ? " multiview" : "");
        EXPECT_GT(out.stats.oitFragments, 0u);
        EXPECT_EQ(out.stats.oitPoolOverflow + out.stats.oitLayersDropped, 0u);
        test::writeOnFailure(out.image.srgb, std::string("particles_") + toString(b) + ".png");
      }
  }
}

// A particle wholly behind the wall changes nothing; the same particle in front does. Also
// without BLEND materials (the lists then exist for the particles alone).
TEST_F(ClusterParticles, HiddenBehindOpaqueGeometry) {
  lod::LodAsset asset = test::bakeScene(wallScene(false));
  auto draw = spriteDraw(context());
  ASSERT_TRUE(draw);
  for (RasterBackend b : test::availableRasterBackends(context())) {
    SCOPED_TRACE(toString(b));
    draw->setCpuBatches({});
    ImageRGBA8 bare = test::renderCluster(context(), asset, particleClusterSettings(b, draw.get())).image.srgb;
    sio::RenderParticle p = test::particleRecord({0.0f, 0.0f, -1.8f}, 1.5f, {1.0f, 0.1f, 0.1f, 1.0f});
    ParticleDraw::CpuBatch batch{{&p, 1}, 0};
    draw->setCpuBatches({&batch, 1});
    ClusterRenderOutput behind = test::renderCluster(context(), asset, particleClusterSettings(b, draw.get()));
    EXPECT_EQ(behind.stats.oitFragments, 0u);
    EXPECT_GE(psnr(bare, behind.image.srgb), 60.0);
    p.position.z = 0.0f;
    draw->setCpuBatches({&batch, 1});
    ClusterRenderOutput front = test::renderCluster(context(), asset, particleClusterSettings(b, draw.get()));
    EXPECT_GT(front.stats.oitFragments, 0u);
    EXPECT_LT(psnr(bare, front.image.srgb), 30.0);
  }
}

// A flat particle over the glass's middle, behind it (z = 0) or in front of it (z = 1): the pixel
// is "over" of the layers in depth order, each layer's colour measured from the renders of the
// wall alone and the wall with the glass (the glass's alpha is its material's 0.4).
TEST_F(ClusterParticles, InterleaveWithBlendedPanel) {
  lod::LodAsset bare = test::bakeScene(wallScene(false)), glass = test::bakeScene(wallScene(true));
  ParticleSheet white{ImageRGBA8{1, 1, {255, 255, 255, 255}}, 1, 1, false};
  auto draw = ParticleDraw::create(context(), {&white, 1});
  ASSERT_TRUE(draw.ok());
  const glm::vec4 color{0.2f, 0.3f, 1.0f, 0.6f};
  const float glassAlpha = 0.4f;
  for (RasterBackend b : test::availableRasterBackends(context())) {
    SCOPED_TRACE(toString(b));
    (*draw)->setCpuBatches({});
    ImageF32 wall = test::renderCluster(context(), bare, particleClusterSettings(b, draw->get())).image.linear;
    ImageF32 withGlass = test::renderCluster(context(), glass, particleClusterSettings(b, draw->get())).image.linear;
    glm::uvec2 c = pixelOf({-0.5f, 0.0f, 0.5f}); // the glass's centre; pixels around it
    for (float z : {0.0f, 1.0f}) {
      sio::RenderParticle p = test::particleRecord({-0.5f, 0.0f, z}, 1.0f, color);
      ParticleDraw::CpuBatch batch{{&p, 1}, 0};
      (*draw)->setCpuBatches({&batch, 1});
      ImageF32 img = test::renderCluster(context(), glass, particleClusterSettings(b, draw->get())).image.linear;
      for (auto [x, y] : {std::pair{c.x, c.y}, {c.x - 5, c.y - 4}, {c.x + 6, c.y + 5}}) {
        glm::vec3 w = test::linearRgbAt(wall, x, y), g = test::linearRgbAt(withGlass, x, y);
        glm::vec3 glassColor = (g - (1.0f - glassAlpha) * w) / glassAlpha;
        glm::vec3 behind = glm::mix(glm::mix(w, glm::vec3(color), color.a), glassColor, glassAlpha);
        glm::vec3 front = glm::mix(g, glm::vec3(color), color.a);
        ASSERT_GT(glm::length(behind - front), 0.05f) << "the test cannot tell the orders apart";
        glm::vec3 want = z < 0.5f ? behind : front, got = test::linearRgbAt(img, x, y);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], want[k], 5e-3f) << (z < 0.5f ? "behind" : "front") << " " << k;
      }
    }
  }
}

} // namespace
