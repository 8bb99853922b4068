// The CPU pool: steps in chunks of the active list (fixed boundaries, so the order of survivors and
// freed slots, and with it every later slot choice, does not depend on the thread count), then a
// serial merge that closes the gaps and returns the dead slots to the inactive stack.
#include <algorithm>
#include <cstring>

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
  size_t capacity = def.maxParticles;
  pool.instances.resize(capacity);
  pool.active.reserve(capacity);
  pool.inactive.resize(capacity);
  for (size_t i = 0; i < capacity; ++i) pool.inactive[i] = uint32_t(capacity - 1 - i); // slot 0 on top
  pool.scratch.resize(capacity);
  pool.chunkLive.resize(chunksFor(capacity));
  for (uint64_t k = prewarmSteps(def, dt); k > 0; --k) stepPool(pool, dt);
  return pool;
}

void stepPool(ParticlePool& pool, float dt) {
  // (1) Age and integrate; each chunk keeps its survivors at its front and its dead in scratch.
  const sio::ParticleParams& params = pool.params;
  uint32_t* active = pool.active.data();
  uint32_t* dead = pool.scratch.data();
  sio::Particle* instances = pool.instances.data();
  size_t n = pool.active.size(), chunks = chunksFor(n);
  forChunks(chunks, [&](size_t c) {
    size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
    uint32_t live = 0, died = 0;
    for (size_t i = begin; i < end; ++i) {
      uint32_t slot = active[i];
      if (sio::particleStep(params, instances[slot], dt))
        active[begin + live++] = slot;
      else
        dead[begin + died++] = slot;
    }
    pool.chunkLive[c] = live;
  });
  // Merge: survivors in order, dead slots onto the inactive stack (capacity reserved: no allocation).
  size_t out = 0;
  for (size_t c = 0; c < chunks; ++c) {
    size_t begin = c * kChunk, end = std::min(n, begin + kChunk), live = pool.chunkLive[c];
    if (out != begin) std::memmove(active + out, active + begin, live * sizeof(uint32_t));
    out += live;
    pool.inactive.insert(pool.inactive.end(), dead + begin, dead + begin + (end - begin - live));
  }
  pool.active.resize(out);
  // (2) Emit at age 0.
  uint32_t request = emitRequest(pool.def, pool.step, dt);
  uint32_t take = uint32_t(std::min<size_t>(request, pool.inactive.size()));
  pool.dropped += request - take;
  for (uint32_t i = 0; i < take; ++i) {
    uint32_t slot = pool.inactive.back();
    pool.inactive.pop_back();
    instances[slot] = sio::particleSpawn(params, pool.nextId++);
    pool.active.push_back(slot);
  }
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
  for (const ParticlePool& p : sim.pools) n += p.active.size();
  return n;
}

size_t writeRenderParticles(const Simulation& sim, std::span<sio::RenderParticle> out) {
  size_t offset = 0;
  for (const ParticlePool& pool : sim.pools) {
    size_t n = std::min(pool.active.size(), out.size() - offset);
    sio::RenderParticle* dst = out.data() + offset;
    forChunks(chunksFor(n), [&](size_t c) {
      size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      for (size_t i = begin; i < end; ++i) dst[i] = sio::particleRender(pool.params, pool.instances[pool.active[i]]);
    });
    offset += n;
  }
  return offset;
}

} // namespace mirage::particles
