// The GPU simulation against the CPU one: the same particles (by spawn index) in the same states
// and render records within float tolerance, the same live counts with prewarm, a full pool and
// several systems; validation layers silent (lavapipe, small counts).
#include <algorithm>
#include <map>

#include "gpu_test.h"
#include "mirage/particles/gpu_simulation.h"
#include "mirage/particles/simulation.h"
#include "particles/particle_test_util.h"

using namespace mirage;
using namespace mirage::particles;
namespace sio = mirage::shaderio;

class GpuParticles : public test::GpuTest {};

namespace {

// Every module on: random force and velocity, rotation, size and colour curves, colour over
// speed, a texture sheet row picked at random, a rotated emitter with a transformed cone.
SystemDef everyModule() {
  SystemDef s;
  s.name = "all";
  s.position = {1.0f, 2.0f, 3.0f};
  s.rotationDegrees = {10.0f, 20.0f, 30.0f};
  s.duration = 1.0f;
  s.startLifetime = {0.5f, 1.5f};
  s.startSpeed = {1.0f, 3.0f};
  s.startSize = {0.1f, 0.3f};
  s.startRotationDegrees = {0.0f, 360.0f};
  s.startColor = {{0.2f, 0.3f, 0.4f, 0.5f}, {1.0f, 1.0f, 1.0f, 1.0f}};
  s.gravityModifier = 0.5f;
  s.maxParticles = 400;
  s.rateOverTime = 300.0f;
  s.seed = 77;
  s.shape.type = ShapeType::Cone;
  s.shape.radius = 0.5f;
  s.shape.angleDegrees = 30.0f;
  s.shape.arcDegrees = 270.0f;
  s.shape.scale = {1.0f, 2.0f, 0.5f};
  s.shape.randomizeDirection = 0.3f;
  s.shape.randomizePosition = 0.05f;
  s.velocityOverLifetime = {{-0.5f, 0.0f, 0.0f}, {0.5f, 0.2f, 0.1f}};
  s.forceOverLifetime = {{0.0f, -1.0f, -0.5f}, {1.0f, 1.0f, 0.5f}};
  s.angularVelocityDegrees = {-90.0f, 90.0f};
  s.sizeOverLifetime.keys = {{0.0f, 0.5f}, {0.5f, 1.5f}, {1.0f, 0.0f}};
  s.colorOverLifetime.times = {0.0f, 1.0f};
  s.colorOverLifetime.colors = {{1, 1, 1, 1}, {1, 0.5f, 0.2f, 0}};
  s.colorOverSpeed.times = {0.0f, 1.0f};
  s.colorOverSpeed.colors = {{0.5f, 0.5f, 0.5f, 1}, {1, 1, 1, 1}};
  s.colorOverSpeedRange = {0.0f, 4.0f};
  s.sheet.tilesX = 4;
  s.sheet.tilesY = 4;
  s.sheet.singleRow = true;
  s.sheet.randomRow = true;
  s.sheet.cycles = 2.0f;
  return s;
}

float relative(glm::vec3 a, glm::vec3 b) { return glm::length(a - b) / (1.0f + glm::length(b)); }

TEST_F(GpuParticles, MatchesCpuParticleForParticle) {
  EffectFile fx;
  fx.systems = {everyModule()};
  Simulation cpu = makeSimulation(fx, test::kStepSeconds);
  GpuSimulation gpu(test::gpuContext(), fx, test::kStepSeconds);
  for (int i = 0; i < 90; ++i) step(cpu);
  gpu.step(90);
  ASSERT_EQ(gpu.liveParticles(), liveParticles(cpu));
  ASSERT_GT(liveParticles(cpu), 100u);
  std::map<uint32_t, sio::Particle> byId;
  for (const sio::Particle& p : gpu.readParticles(0)) byId[p.id] = p;
  const ParticlePool& pool = cpu.pools[0];
  ASSERT_EQ(byId.size(), pool.live);
  for (uint32_t i = 0; i < pool.live; ++i) {
    const sio::Particle& c = pool.instances[i];
    auto it = byId.find(c.id);
    ASSERT_NE(it, byId.end()) << "particle " << c.id << " missing on the GPU";
    const sio::Particle& g = it->second;
    EXPECT_LT(relative(g.position, c.position), 1e-4f) << c.id;
    EXPECT_LT(relative(g.velocity, c.velocity), 1e-4f) << c.id;
    EXPECT_NEAR(g.age, c.age, 1e-5f) << c.id;
    EXPECT_NEAR(g.lifetime, c.lifetime, 1e-5f) << c.id;
  }
  // Render records, matched by id.
  std::vector<sio::RenderParticle> cpuRecords(liveParticles(cpu));
  writeRenderParticles(cpu, cpuRecords);
  test::gpuContext().submitAndWait([&](VkCommandBuffer cmd) { gpu.cmdWriteRender(cmd); });
  std::vector<sio::RenderParticle> gpuRecords = gpu.readRender();
  ASSERT_EQ(gpuRecords.size(), cpuRecords.size());
  auto byIdOrder = [](const sio::RenderParticle& a, const sio::RenderParticle& b) { return a.id < b.id; };
  std::sort(cpuRecords.begin(), cpuRecords.end(), byIdOrder);
  std::sort(gpuRecords.begin(), gpuRecords.end(), byIdOrder);
  size_t frameDiffers = 0;
  for (size_t i = 0; i < cpuRecords.size(); ++i) {
    const sio::RenderParticle &c = cpuRecords[i], &g = gpuRecords[i];
    ASSERT_EQ(c.id, g.id);
    EXPECT_LT(relative(g.position, c.position), 1e-4f);
    EXPECT_NEAR(g.size, c.size, 1e-4f * (1.0f + c.size));
    EXPECT_NEAR(g.rotation, c.rotation, 1e-4f * (1.0f + std::abs(c.rotation)));
    glm::vec4 cc = glm::unpackUnorm4x8(c.color), gc = glm::unpackUnorm4x8(g.color);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(gc[k], cc[k], 1.5f / 255.0f);
    frameDiffers += c.frame != g.frame; // only where a rounding lands on a frame boundary
  }
  EXPECT_LE(frameDiffers, cpuRecords.size() / 100);
}

// A step that writes the render records itself (update and emission appending them) leaves the
// records, and their count, that the output pass leaves after a plain step: twin simulations, one
// of each, matched by id, within float precision (the same formulas in different passes).
TEST_F(GpuParticles, StepWritingRecordsMatchesTheOutputPass) {
  EffectFile fx;
  fx.systems = {everyModule(), everyModule()};
  fx.systems[1].name = "second";
  fx.systems[1].seed += 7;
  GpuSimulation fused(test::gpuContext(), fx, test::kStepSeconds), separate(test::gpuContext(), fx, test::kStepSeconds);
  fused.step(60);
  separate.step(60);
  test::gpuContext().submitAndWait([&](VkCommandBuffer cmd) { fused.cmdStep(cmd, /*writeRender=*/true); });
  test::gpuContext().submitAndWait([&](VkCommandBuffer cmd) {
    separate.cmdStep(cmd);
    separate.cmdWriteRender(cmd);
  });
  ASSERT_EQ(fused.liveParticles(), separate.liveParticles());
  std::vector<sio::RenderParticle> a = fused.readRender(), b = separate.readRender();
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 200u);
  auto byId = [](const sio::RenderParticle& x, const sio::RenderParticle& y) {
    return x.id != y.id ? x.id < y.id : x.position.x < y.position.x; // two systems share ids
  };
  std::sort(a.begin(), a.end(), byId);
  std::sort(b.begin(), b.end(), byId);
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].id, b[i].id);
    EXPECT_LT(relative(a[i].position, b[i].position), 1e-6f);
    EXPECT_NEAR(a[i].size, b[i].size, 1e-6f * (1.0f + b[i].size));
    EXPECT_NEAR(a[i].rotation, b[i].rotation, 1e-6f * (1.0f + std::abs(b[i].rotation)));
    glm::vec4 ca = glm::unpackUnorm4x8(a[i].color), cb = glm::unpackUnorm4x8(b[i].color);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(ca[k], cb[k], 1.5f / 255.0f);
  }
}

// Two GPU runs hold the same particles bit for bit (slots may differ: the dead stack fills in any
// order, so compare by spawn index).
TEST_F(GpuParticles, DeterministicBySpawnIndex) {
  EffectFile fx;
  fx.systems = {everyModule()};
  auto run = [&] {
    GpuSimulation gpu(test::gpuContext(), fx, test::kStepSeconds);
    gpu.step(75);
    std::vector<sio::Particle> particles = gpu.readParticles(0);
    std::sort(particles.begin(), particles.end(),
              [](const sio::Particle& a, const sio::Particle& b) { return a.id < b.id; });
    return particles;
  };
  std::vector<sio::Particle> a = run(), b = run();
  ASSERT_GT(a.size(), 100u);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])), 0);
}

TEST_F(GpuParticles, LiveCountsWithPrewarmFullPoolAndSeveralSystems) {
  EffectFile fx;
  SystemDef a = everyModule();
  a.prewarm = true;
  a.looping = true;
  SystemDef b = everyModule();
  b.name = "full";
  b.maxParticles = 50; // emission outruns the pool
  b.seed = 5;
  SystemDef c = everyModule();
  c.name = "late";
  c.startDelay = 0.5f;
  c.looping = false;
  fx.systems = {a, b, c};
  Simulation cpu = makeSimulation(fx, test::kStepSeconds);
  GpuSimulation gpu(test::gpuContext(), fx, test::kStepSeconds);
  ASSERT_EQ(gpu.liveParticles(), liveParticles(cpu)); // after prewarm
  for (int round = 0; round < 3; ++round) {
    for (int i = 0; i < 30; ++i) step(cpu);
    gpu.step(30);
    EXPECT_EQ(gpu.liveParticles(), liveParticles(cpu)) << round;
  }
  EXPECT_EQ(cpu.pools[1].live, 50u);
}

} // namespace
