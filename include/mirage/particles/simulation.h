#pragma once
// The CPU particle simulation (docs/particles.md, seed 004 ch. 5.4): one pool per system, sized
// once (max particles) so no step allocates; steps of a fixed dt run in parallel over systems and,
// within a large system, over ranges of its live particles (oneTBB). A run is deterministic for a seed: every random
// number is a hash of (seed, particle id, attribute) (shaderio/particles.h), and the GPU simulation (gpu_simulation.h)
// evaluates the same formulas.
//
// A step: (1) every live particle ages by dt and dies at its lifetime, else takes one
// semi-implicit Euler step (particleStep); (2) the system emits emitRequest(step) particles at age
// 0 (fewer when the pool is full: `dropped` counts the rest). The output for a renderer is an array
// of shaderio::RenderParticle (position, size, rotation, RGBA8 colour, sheet frame, id).
#include <cstdint>
#include <span>
#include <vector>

#include "mirage/particles/effect.h"
#include "mirage/shaderio/particles.h"

namespace mirage::particles {

// Gravity before the modifier (world units / s^2, +Y up).
constexpr float kGravity = 9.81f;

// A system's parameters for the shared formulas: angles to radians, the emitter and shape
// transforms folded into matrices, curves and gradients copied into fixed arrays.
shaderio::ParticleParams flattenSystem(const SystemDef& system);

// Particles a system has emitted by time t (seconds since the start; start delay, duration,
// looping and prewarm applied): floor(rate * emitting time) per cycle. The CPU and GPU
// simulations both emit emittedBy(t(k+1)) - emittedBy(t(k)) in step k (emitRequest).
uint64_t emittedBy(const SystemDef& system, double t);
// Step k runs from t = k dt to (k + 1) dt; prewarm steps count (makePool runs them).
uint32_t emitRequest(const SystemDef& system, uint64_t step, float dt);
// Steps that prewarm runs before the first visible step: ceil(duration / dt), 0 without prewarm.
uint64_t prewarmSteps(const SystemDef& system, float dt);

// One system's pool: `instances` holds max particles slots, sized once; the live particles are
// the dense front [0, live) (the active list) and the slots [live, capacity) the free ones (the
// inactive list). A particle that dies takes the last live one into its slot (swap-remove, in
// descending slot order so the result is fixed). Dense storage, rather than active/inactive
// index lists over scattered slots, keeps every step a sequential sweep: with index lists the
// slots scattered after a few lifetimes and a 1 M step cost 67 ns per particle in cache misses.
// `dead` and `chunkDead` are the step's scratch (deaths per chunk before the removal).
struct ParticlePool {
  SystemDef def;
  shaderio::ParticleParams params;
  std::vector<shaderio::Particle> instances;
  uint32_t live = 0;
  std::vector<uint32_t> dead;
  std::vector<uint32_t> chunkDead;
  uint64_t step = 0;    // steps taken (prewarm included)
  uint32_t nextId = 0;  // spawn index of the next particle
  uint64_t dropped = 0; // emissions refused by a full pool
};

// A pool of def.maxParticles slots, every one inactive. With prewarm, runs prewarmSteps first.
ParticlePool makePool(const SystemDef& def, float dt);
void stepPool(ParticlePool& pool, float dt);

// Every system of an effect, stepped together.
struct Simulation {
  std::vector<ParticlePool> pools;
  float dt = 1.0f / 60.0f;
};
Simulation makeSimulation(const EffectFile& effect, float dt);
// One step of every pool, in parallel over pools (and over particles within each).
void step(Simulation& sim);
uint64_t liveParticles(const Simulation& sim);
// The render records of every live particle, pool after pool in slot order; `out` must hold
// liveParticles(sim) records. Returns the number written.
size_t writeRenderParticles(const Simulation& sim, std::span<shaderio::RenderParticle> out);

// A benchmark variant of an effect: the systems share `count` particles (max particles split in
// proportion to the file's), each emitting fast enough to fill its pool within a quarter of its
// shortest lifetime, looping, without start delay or prewarm.
EffectFile scaleEffect(const EffectFile& effect, uint64_t count);
// Steps until every pool of a scaled effect is full (ceil(max lifetime / dt), at most a limit).
uint64_t fillSteps(const EffectFile& effect, float dt);

} // namespace mirage::particles
