// The CPU pool: steps in chunks of the live range (fixed boundaries, so the list of deaths, and with
// it every later slot, does not depend on the thread count), then a serial swap-remove of the dead.
#include <algorithm>

#include <tbb/parallel_for.h>

#include "mirage/particles/simulation.h"

namespace mirage::particles {

namespace sio = mirage::shaderio;

namespace {

// Particles per chunk: large enough to amortize a task, small enough to balance two cores.
constexpr size_t kChunk = 16384;

size_t chunksFor(size_t n) { return (n + kChunk - 1) / kChunk; }

template <class F> void forChunks(size_t chunks, F&& body) {
  if (chunks <= 1) {
    for (size_t c = 0; c < chunks; ++c) body(c);
    return;
  }
  tbb::parallel_for(size_t(0), chunks, [&](size_t c) { body(c); });
}

} // namespace

ParticlePool makePool(const SystemDef& def, float dt) {
  ParticlePool pool;
  pool.def = def;
  pool.params = flattenSystem(def);
  pool.instances.resize(def.maxParticles);
  pool.dead.resize(def.maxParticles);
  pool.chunkDead.resize(chunksFor(def.maxParticles));
  for (uint64_t k = prewarmSteps(def, dt); k > 0; --k) stepPool(pool, dt);
  return pool;
}

void stepPool(ParticlePool& pool, float dt) {
  // (1) Age and integrate in parallel; each chunk lists its deaths at its own offset in `dead`.
  sio::Particle* instances = pool.instances.data();
  uint32_t* dead = pool.dead.data();
  size_t n = pool.live, chunks = chunksFor(n);
  forChunks(chunks, [&](size_t c) {
    size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
    uint32_t died = 0;
    for (size_t i = begin; i < end; ++i)
      if (!sio::particleStep(instances[i], dt)) dead[begin + died++] = uint32_t(i);
    pool.chunkDead[c] = died;
  });
  // Swap-remove in descending slot order: every slot above the one removed is live by then, so the
  // last live particle moves into it (or it is the last one).
  uint32_t live = pool.live;
  for (size_t c = chunks; c-- > 0;)
    for (uint32_t k = pool.chunkDead[c]; k-- > 0;) {
      uint32_t slot = dead[c * kChunk + k];
      instances[slot] = instances[--live];
    }
  // (2) Emit at age 0 into the free slots after the live ones.
  uint32_t request = emitRequest(pool.def, pool.step, dt);
  uint32_t take = std::min<uint32_t>(request, uint32_t(pool.instances.size()) - live);
  pool.dropped += request - take;
  // In parallel too: a spawn (shape sample, seven random draws, trigonometry) costs more than a
  // step, and short-lived effects replace a few percent of their particles every step.
  sio::Particle* spawned = instances + live;
  uint32_t firstId = pool.nextId;
  forChunks(chunksFor(take), [&](size_t c) {
    size_t begin = c * kChunk, end = std::min<size_t>(take, begin + kChunk);
    for (size_t i = begin; i < end; ++i) spawned[i] = sio::particleSpawn(pool.params, firstId + uint32_t(i));
  });
  pool.nextId += take;
  pool.live = live + take;
  ++pool.step;
}

Simulation makeSimulation(const EffectFile& effect, float dt) {
  Simulation sim;
  sim.dt = dt;
  sim.pools.resize(effect.systems.size());
  tbb::parallel_for(size_t(0), effect.systems.size(),
                    [&](size_t i) { sim.pools[i] = makePool(effect.systems[i], dt); });
  return sim;
}

void step(Simulation& sim) {
  tbb::parallel_for(size_t(0), sim.pools.size(), [&](size_t i) { stepPool(sim.pools[i], sim.dt); });
}

uint64_t liveParticles(const Simulation& sim) {
  uint64_t n = 0;
  for (const ParticlePool& p : sim.pools) n += p.live;
  return n;
}

size_t writeRenderParticles(const Simulation& sim, std::span<sio::RenderParticle> out) {
  size_t offset = 0;
  for (const ParticlePool& pool : sim.pools) {
    size_t n = std::min<size_t>(pool.live, out.size() - offset);
    sio::RenderParticle* dst = out.data() + offset;
    forChunks(chunksFor(n), [&](size_t c) {
      size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      for (size_t i = begin; i < end; ++i) dst[i] = sio::particleRender(pool.params, pool.instances[i]);
    });
    offset += n;
  }
  return offset;
}

} // namespace mirage::particles
