// The CPU simulation against the analytic law of each module: constant velocity, gravity under
// semi-implicit Euler, size and colour curves at known ages, emission counts from rate, duration,
// looping, prewarm and start delay, and the pool's limits; determinism; generated sheets.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mirage/particles/sheet.h"
#include "mirage/particles/simulation.h"
#include "particles/particle_test_util.h"

using namespace mirage;
using namespace mirage::particles;
namespace sio = mirage::shaderio;

namespace {

// A point emitter (an edge of length 0) sending particles up at `speed`, living `lifetime` s.
SystemDef pointSystem(float speed, float lifetime) {
  SystemDef s;
  s.shape.type = ShapeType::Edge;
  s.shape.radius = 0.0f;
  s.startSpeed = {speed, speed};
  s.startLifetime = {lifetime, lifetime};
  s.rateOverTime = 60.0f;
  s.duration = 100.0f;
  s.maxParticles = 10000;
  return s;
}

void run(ParticlePool& pool, int steps) {
  for (int i = 0; i < steps; ++i) stepPool(pool, test::kStepSeconds);
}

// The first particle emitted (spawn index 0).
const sio::Particle& oldest(const ParticlePool& pool) {
  for (uint32_t i = 0; i < pool.live; ++i)
    if (pool.instances[i].id == 0) return pool.instances[i];
  ADD_FAILURE() << "particle 0 is not alive";
  return pool.instances.at(0);
}

TEST(ParticleSim, ConstantVelocity) {
  SystemDef s = pointSystem(2.0f, 100.0f);
  s.velocityOverLifetime.min = s.velocityOverLifetime.max = glm::vec3(0.5f, 0.0f, 0.0f);
  s.position = {1.0f, 2.0f, 3.0f};
  ParticlePool pool = makePool(s, test::kStepSeconds);
  run(pool, 120);
  const sio::Particle& p = oldest(pool);
  ASSERT_EQ(p.id, 0u);
  float t = p.age;
  EXPECT_NEAR(t, 119 * test::kStepSeconds, 1e-4f); // emitted at the end of step 0, aged by the 119 steps after it
  glm::vec3 expected = s.position + glm::vec3(0.5f, 2.0f, 0.0f) * t;
  EXPECT_NEAR(glm::length(p.position - expected), 0.0f, 1e-4f);
  EXPECT_EQ(p.velocity, glm::vec3(0.5f, 2.0f, 0.0f)); // start velocity + velocity over lifetime, no acceleration
}

TEST(ParticleSim, GravityFollowsSemiImplicitEuler) {
  SystemDef s = pointSystem(3.0f, 100.0f);
  s.gravityModifier = 1.0f;
  ParticlePool pool = makePool(s, test::kStepSeconds);
  run(pool, 61);
  const sio::Particle& p = oldest(pool);
  int m = int(std::lround(p.age / test::kStepSeconds));
  ASSERT_EQ(m, 60);
  double g = -kGravity, dt = test::kStepSeconds;
  // v_m = v0 + g m dt, x_m = v0 m dt + g dt^2 m (m + 1) / 2.
  EXPECT_NEAR(p.velocity.y, 3.0 + g * m * dt, 1e-4);
  EXPECT_NEAR(p.position.y, 3.0 * m * dt + g * dt * dt * m * (m + 1) / 2.0, 1e-4);
  // Within the method's first-order error of the continuous law x = v0 t + g t^2 / 2.
  double t = m * dt;
  EXPECT_NEAR(p.position.y, 3.0 * t + 0.5 * g * t * t, 0.5 * std::abs(g) * dt * t + 1e-4);
}

TEST(ParticleSim, ForceAccelerates) {
  SystemDef s = pointSystem(0.0f, 100.0f);
  s.forceOverLifetime.min = s.forceOverLifetime.max = glm::vec3(0.0f, 0.0f, 2.0f);
  ParticlePool pool = makePool(s, test::kStepSeconds);
  run(pool, 31);
  const sio::Particle& p = oldest(pool);
  EXPECT_NEAR(p.velocity.z, 2.0f * 30 * test::kStepSeconds, 1e-5f);
  // A random force stays within its range: velocity / age per axis.
  s.forceOverLifetime.min = glm::vec3(-1.0f, 0.0f, 1.0f);
  s.forceOverLifetime.max = glm::vec3(1.0f, 0.0f, 3.0f);
  ParticlePool random = makePool(s, test::kStepSeconds);
  run(random, 31);
  for (uint32_t i = 0; i < random.live; ++i) {
    const sio::Particle& q = random.instances[i];
    if (q.age <= 0.0f) continue;
    glm::vec3 a = q.velocity / q.age;
    EXPECT_LE(std::abs(a.x), 1.0f + 1e-3f);
    EXPECT_GE(a.z, 1.0f - 1e-3f);
    EXPECT_LE(a.z, 3.0f + 1e-3f);
  }
}

// A renderable particle at normalized age t of a lifetime of 1 s.
sio::RenderParticle renderAt(const SystemDef& s, float t) {
  sio::ParticleParams e = flattenSystem(s);
  sio::Particle p = sio::particleSpawn(e, 0);
  p.age = t * p.lifetime;
  return sio::particleRender(e, p);
}

TEST(ParticleSim, SizeCurveAtKnownAges) {
  SystemDef s = pointSystem(1.0f, 1.0f);
  s.startSize = {2.0f, 2.0f};
  s.sizeOverLifetime.keys = {{0.0f, 1.0f}, {0.5f, 3.0f}, {1.0f, 0.0f}};
  EXPECT_NEAR(renderAt(s, 0.0f).size, 2.0f, 1e-5f);
  EXPECT_NEAR(renderAt(s, 0.25f).size, 4.0f, 1e-5f);
  EXPECT_NEAR(renderAt(s, 0.5f).size, 6.0f, 1e-5f);
  EXPECT_NEAR(renderAt(s, 0.75f).size, 3.0f, 1e-5f);
  EXPECT_NEAR(renderAt(s, 1.0f).size, 0.0f, 1e-5f);
}

glm::vec4 unpack(uint32_t c) { return glm::unpackUnorm4x8(c); }

TEST(ParticleSim, ColorGradientAndSpeedAtKnownValues) {
  SystemDef s = pointSystem(1.0f, 1.0f);
  s.colorOverLifetime.times = {0.0f, 1.0f};
  s.colorOverLifetime.colors = {{1, 0, 0, 1}, {0, 0, 1, 0.5f}};
  for (float t : {0.0f, 0.3f, 0.7f, 1.0f}) {
    glm::vec4 c = unpack(renderAt(s, t).color);
    EXPECT_NEAR(c.r, 1.0f - t, 1.0f / 255);
    EXPECT_NEAR(c.b, t, 1.0f / 255);
    EXPECT_NEAR(c.a, 1.0f - 0.5f * t, 1.0f / 255);
  }
  // Colour over speed: speed 1 in a range [0, 4] reads the gradient at 0.25.
  s.colorOverSpeed.times = {0.0f, 1.0f};
  s.colorOverSpeed.colors = {{1, 1, 1, 1}, {1, 1, 1, 0}};
  s.colorOverSpeedRange = {0.0f, 4.0f};
  EXPECT_NEAR(unpack(renderAt(s, 0.0f).color).a, 0.75f, 1.0f / 255);
}

TEST(ParticleSim, RotationAndSheetFrame) {
  SystemDef s = pointSystem(1.0f, 1.0f);
  s.startRotationDegrees = {90.0f, 90.0f};
  s.angularVelocityDegrees = {180.0f, 180.0f};
  EXPECT_NEAR(renderAt(s, 0.5f).rotation, glm::radians(90.0f + 90.0f), 1e-5f);
  s.sheet.tilesX = 4;
  s.sheet.tilesY = 2;
  s.sheet.cycles = 1.0f;
  EXPECT_EQ(renderAt(s, 0.0f).frame, 0u);
  EXPECT_EQ(renderAt(s, 0.5f).frame, 4u); // 8 frames over the lifetime
  EXPECT_EQ(renderAt(s, 0.99f).frame, 7u);
  s.sheet.singleRow = true;
  s.sheet.row = 1;
  EXPECT_EQ(renderAt(s, 0.5f).frame, 4u + 2u); // row 1, frame 2 of 4
}

uint64_t liveAfter(const SystemDef& s, double seconds) {
  ParticlePool pool = makePool(s, test::kStepSeconds);
  run(pool, int(std::lround(seconds / test::kStepSeconds)));
  return pool.live;
}

TEST(ParticleSim, EmissionCounts) {
  SystemDef s = pointSystem(0.0f, 1000.0f);
  s.rateOverTime = 100.0f;
  s.duration = 2.0f;
  s.looping = false;
  EXPECT_EQ(liveAfter(s, 1.0), 100u);
  EXPECT_EQ(liveAfter(s, 3.0), 200u); // emission stops after the duration
  s.looping = true;
  EXPECT_EQ(liveAfter(s, 3.0), 300u);
  s.startDelay = 0.5f;
  EXPECT_EQ(liveAfter(s, 0.4), 0u);
  EXPECT_EQ(liveAfter(s, 1.0), 50u);
  s.startDelay = 0.0f;
  s.prewarm = true; // one whole cycle has run before the first step
  EXPECT_EQ(makePool(s, test::kStepSeconds).live, 200u);
  EXPECT_EQ(liveAfter(s, 1.0), 300u);
}

TEST(ParticleSim, LifetimeBoundsTheLiveCount) {
  SystemDef s = pointSystem(0.0f, 0.5f);
  s.rateOverTime = 120.0f; // two per step
  // Steady state: rate * lifetime particles (each lives 30 steps: 60 alive), whatever the time.
  EXPECT_EQ(liveAfter(s, 2.0), 60u);
  EXPECT_EQ(liveAfter(s, 5.0), 60u);
}

TEST(ParticleSim, MaxParticlesAndNoAllocationAfterWarmUp) {
  SystemDef s = pointSystem(1.0f, 0.7f);
  s.rateOverTime = 3000.0f;
  s.maxParticles = 1000;
  ParticlePool pool = makePool(s, test::kStepSeconds);
  const void* buffers[] = {pool.instances.data(), pool.dead.data(), pool.chunkDead.data()};
  size_t capacities[] = {pool.instances.capacity(), pool.dead.capacity(), pool.chunkDead.capacity()};
  for (int i = 0; i < 200; ++i) {
    stepPool(pool, test::kStepSeconds);
    ASSERT_LE(pool.live, 1000u);
    ASSERT_EQ(pool.instances.size(), 1000u);
  }
  EXPECT_EQ(pool.live, 1000u);
  EXPECT_GT(pool.dropped, 0u);
  const void* after[] = {pool.instances.data(), pool.dead.data(), pool.chunkDead.data()};
  size_t capacitiesAfter[] = {pool.instances.capacity(), pool.dead.capacity(), pool.chunkDead.capacity()};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(buffers[i], after[i]) << i;
    EXPECT_EQ(capacities[i], capacitiesAfter[i]) << i;
  }
}

std::vector<sio::RenderParticle> runEffect(const EffectFile& fx, int steps) {
  Simulation sim = makeSimulation(fx, test::kStepSeconds);
  for (int i = 0; i < steps; ++i) step(sim);
  std::vector<sio::RenderParticle> out(liveParticles(sim));
  EXPECT_EQ(writeRenderParticles(sim, out), out.size());
  return out;
}

EffectFile example(const char* name) {
  auto fx = loadEffectFile(std::filesystem::path(MIRAGE_SOURCE_DIR) / "examples/particles" / name);
  EXPECT_TRUE(fx.ok()) << fx.error().message;
  return fx.ok() ? *fx : EffectFile{};
}

TEST(ParticleSim, DeterministicAcrossRunsAndThreadCounts) {
  // Large enough for several chunks per pool (parallel within a system).
  EffectFile fx = scaleEffect(example("fire.toml"), 60000);
  std::vector<sio::RenderParticle> a = runEffect(fx, 90), b = runEffect(fx, 90), c;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    c = runEffect(fx, 90);
  }
  ASSERT_GT(a.size(), 30000u);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), c.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])), 0);
  EXPECT_EQ(std::memcmp(a.data(), c.data(), a.size() * sizeof(a[0])), 0);
  // Another seed changes the result.
  fx.systems[0].seed += 1;
  std::vector<sio::RenderParticle> d = runEffect(fx, 90);
  EXPECT_FALSE(d.size() == a.size() && std::memcmp(a.data(), d.data(), a.size() * sizeof(a[0])) == 0);
}

TEST(ParticleSim, ScaledEffectFillsItsPools) {
  EffectFile fx = scaleEffect(example("fire.toml"), 5000);
  Simulation sim = makeSimulation(fx, test::kStepSeconds);
  for (uint64_t i = 0; i < fillSteps(fx, test::kStepSeconds); ++i) step(sim);
  EXPECT_EQ(liveParticles(sim), 5000u);
}

// Fewer particles than systems: every system gets at least one, and the last one's remainder
// must not underflow (it would clamp to 2^26 particles, gigabytes of pool).
TEST(ParticleSim, ScaledEffectWithFewerParticlesThanSystems) {
  EffectFile fx = scaleEffect(example("fire.toml"), 1);
  ASSERT_EQ(fx.systems.size(), 3u);
  for (const SystemDef& s : fx.systems) EXPECT_EQ(s.maxParticles, 1u) << s.name;
  fx = scaleEffect(example("fire.toml"), 2200); // the file's own proportions: 1500, 300, 400
  EXPECT_EQ(fx.systems[0].maxParticles, 1500u);
  EXPECT_EQ(fx.systems[1].maxParticles, 300u);
  EXPECT_EQ(fx.systems[2].maxParticles, 400u);
}

TEST(ParticleSheet, GeneratedDeterministicAndShaped) {
  for (const char* kind : {"puff", "spark", "flame", "drop", "none"}) {
    auto a = generateSheet(kind, 4, 2, 32), b = generateSheet(kind, 4, 2, 32);
    ASSERT_TRUE(a.ok()) << kind;
    EXPECT_EQ(a->width, 128u);
    EXPECT_EQ(a->height, 64u);
    EXPECT_EQ(a->pixels, b->pixels) << kind;
    EXPECT_GT(a->at(16, 16)[3], 64) << kind;               // frame 0's centre is covered
    EXPECT_LT(a->at(0, 0)[3], 32) << kind;                 // its corner is not
    EXPECT_EQ(a->at(16, 16)[0], a->at(16, 16)[3]) << kind; // grey = alpha
  }
  EXPECT_FALSE(generateSheet("lava", 4, 4, 32).ok());
  EXPECT_FALSE(generateSheet("puff", 0, 4, 32).ok());
  EXPECT_FALSE(generateSheet("puff", 64, 64, 128).ok());
}

} // namespace
