#pragma once
// Set-up shared by the particle tests: the simulation step, and for the rendering tests
// (particle_render_test.cpp, particle_splat_test.cpp) the forward renderer's view of the origin from
// (0, 0, kParticleDistance), scenes that are never empty, a plain white sheet and particle records.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/particle_draw.h"
#include "render/render_test_util.h" // renderForward
#include "test_scenes.h"

namespace mirage::test {

// The simulation step: one frame at 60 Hz.
inline constexpr float kStepSeconds = 1.0f / 60.0f;

// The camera's distance from the origin (looking down -z) and its vertical field of view.
inline constexpr float kParticleDistance = 5.0f, kParticleFov = 45.0f;

// A size x size view from (0, 0, kParticleDistance) at the origin, the linear image read back.
inline render::ForwardRenderSettings particleView(uint32_t size, render::OitMode mode, render::ParticleDraw* particles,
                                                  glm::vec4 background) {
  render::ForwardRenderSettings s;
  s.base.width = s.base.height = size;
  s.base.camera.eye = {0, 0, kParticleDistance};
  s.base.camera.fovYDegrees = kParticleFov;
  s.base.camera.znear = 0.1f;
  s.base.camera.zfar = 100.0f;
  s.base.background = background;
  s.base.readLinear = true;
  s.oit = mode;
  s.particles = particles;
  return s;
}

// `meshes` (materials one each) and, out of view, a tiny opaque quad: a scene is never empty.
inline Scene withAnchor(std::vector<Mesh> meshes, std::vector<Material> materials) {
  meshes.push_back(makeQuad(0.01f, 0.0f, uint32_t(materials.size())));
  materials.push_back(solidMaterial({1, 1, 1, 1}));
  Scene s = makeScene(std::move(meshes), std::move(materials));
  s.instances.back().transform = glm::translate(glm::mat4(1.0f), {50.0f, 0.0f, 0.0f});
  return s;
}

// A draw with one sheet of one white texel: particles show their record colour.
inline std::unique_ptr<render::ParticleDraw> whiteParticleDraw(gpu::Context& ctx) {
  render::ParticleSheet white{ImageRGBA8{1, 1, {255, 255, 255, 255}}, 1, 1, false};
  auto d = render::ParticleDraw::create(ctx, {&white, 1});
  EXPECT_TRUE(d.ok()) << (d.ok() ? "" : d.error().message);
  return d.ok() ? std::move(*d) : nullptr;
}

// `records` as the draw's one batch (from sheet `sheet`), copied.
inline void showParticles(render::ParticleDraw& draw, std::span<const shaderio::RenderParticle> records,
                          uint32_t sheet = 0) {
  render::ParticleDraw::CpuBatch batch{records, sheet};
  draw.setCpuBatches({&batch, 1});
}

inline shaderio::RenderParticle particleRecord(glm::vec3 position, float size, glm::vec4 color, float rotation = 0.0f,
                                               uint32_t frame = 0) {
  return {position, size, rotation, shaderio::particlePackColor(color), frame, 0};
}

} // namespace mirage::test
