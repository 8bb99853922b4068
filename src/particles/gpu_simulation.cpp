// GPU pools: buffers reached through device addresses in push constants (no descriptors), one
// pipeline per pass shared by every system; a global compute barrier between passes.
#include "mirage/particles/gpu_simulation.h"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/particles/simulation.h"

namespace mirage::particles {

namespace sio = mirage::shaderio;

struct GpuSimulation::System {
  SystemDef def;
  uint32_t capacity = 0;
  uint64_t step = 0; // steps taken (prewarm included), as ParticlePool::step
  gpu::Buffer params, particles, alive, dead, counters, render;
};

namespace {

void cmdComputeBarrier(VkCommandBuffer cmd) {
  gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                        VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                        VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT |
                            VK_ACCESS_2_TRANSFER_WRITE_BIT);
}

uint32_t groupsFor(uint32_t threads) { return (threads + MIRAGE_PARTICLE_GROUP - 1) / MIRAGE_PARTICLE_GROUP; }

} // namespace

GpuSimulation::GpuSimulation(gpu::Context& context, const EffectFile& effect, float dt) : context_(context), dt_(dt) {
  layout_ = gpu::createPipelineLayout(context, {}, sizeof(sio::ParticlePush), VK_SHADER_STAGE_COMPUTE_BIT);
  update_ = gpu::createComputePipeline(context, "particles_update.comp", layout_);
  emit_ = gpu::createComputePipeline(context, "particles_emit.comp", layout_);
  finish_ = gpu::createComputePipeline(context, "particles_finish.comp", layout_);
  output_ = gpu::createComputePipeline(context, "particles_output.comp", layout_);
  constexpr VkBufferUsageFlags kUsage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  for (const SystemDef& def : effect.systems) {
    auto s = std::make_unique<System>();
    s->def = def;
    s->capacity = def.maxParticles;
    size_t n = s->capacity;
    sio::ParticleParams params = flattenSystem(def);
    s->params =
        gpu::createBufferWithData(context, std::span<const sio::ParticleParams>(&params, 1), kUsage, "particle params");
    s->particles =
        gpu::createBuffer(context, n * sizeof(sio::Particle), kUsage, gpu::MemoryUsage::GpuOnly, "particles");
    s->alive = gpu::createBuffer(context, n * 4, kUsage, gpu::MemoryUsage::GpuOnly, "particle alive flags");
    s->render = gpu::createBuffer(context, n * sizeof(sio::RenderParticle), kUsage | VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                  gpu::MemoryUsage::GpuOnly, "particle render records");
    // The dead stack holds every slot, slot 0 on top.
    std::vector<uint32_t> dead(n);
    for (size_t i = 0; i < n; ++i) dead[i] = uint32_t(n - 1 - i);
    s->dead = gpu::createBufferWithData(context, std::span<const uint32_t>(dead), kUsage, "particle dead stack");
    sio::ParticleCounters counters{uint32_t(n), 0, 0, 0};
    s->counters = gpu::createBufferWithData(context, std::span<const sio::ParticleCounters>(&counters, 1),
                                            kUsage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, "particle counters");
    systems_.push_back(std::move(s));
  }
  context.submitAndWait([&](VkCommandBuffer cmd) {
    for (auto& s : systems_) vkCmdFillBuffer(cmd, s->alive.handle(), 0, VK_WHOLE_SIZE, 0);
  });
  // Prewarm, one system at a time (each runs its own number of steps).
  for (auto& s : systems_) {
    uint64_t steps = prewarmSteps(s->def, dt_);
    while (steps > 0) {
      uint64_t batch = std::min<uint64_t>(steps, 256);
      context.submitAndWait([&](VkCommandBuffer cmd) {
        for (uint64_t k = 0; k < batch; ++k) {
          uint32_t emit = emitRequest(s->def, s->step, dt_);
          cmdComputeBarrier(cmd);
          cmdPass(cmd, update_, *s, s->capacity, 0);
          cmdComputeBarrier(cmd);
          cmdPass(cmd, emit_, *s, emit, emit);
          cmdComputeBarrier(cmd);
          cmdPass(cmd, finish_, *s, 1, 0);
          ++s->step;
        }
      });
      steps -= batch;
    }
  }
}

GpuSimulation::~GpuSimulation() = default;

void GpuSimulation::cmdPass(VkCommandBuffer cmd, VkPipeline pipeline, const System& s, uint32_t threads, uint32_t emit,
                            bool writeRender) {
  if (threads == 0) return;
  sio::ParticlePush p{};
  p.params = s.params.address();
  p.particles = s.particles.address();
  p.alive = s.alive.address();
  p.dead = s.dead.address();
  p.counters = s.counters.address();
  p.render = s.render.address();
  p.capacity = s.capacity;
  p.emit = emit;
  p.dt = dt_;
  p.writeRender = writeRender ? 1u : 0u;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
  // Large pools dispatch several rows (particleIndex in particles_common.glsl).
  gpu::DispatchRows rows = gpu::dispatchRows(groupsFor(threads));
  vkCmdDispatch(cmd, rows.x, rows.y, 1);
}

void GpuSimulation::cmdStep(VkCommandBuffer cmd, bool writeRender) {
  // Each phase for every system, then one barrier: independent systems overlap on the GPU.
  cmdComputeBarrier(cmd);
  if (writeRender) { // the records' counter, zeroed before update and emit append to it
    for (auto& s : systems_) vkCmdFillBuffer(cmd, s->counters.handle(), offsetof(sio::ParticleCounters, live), 4, 0);
    cmdComputeBarrier(cmd);
  }
  for (auto& s : systems_) cmdPass(cmd, update_, *s, s->capacity, 0, writeRender);
  cmdComputeBarrier(cmd);
  for (auto& s : systems_) {
    uint32_t emit = emitRequest(s->def, s->step, dt_);
    cmdPass(cmd, emit_, *s, emit, emit, writeRender);
  }
  cmdComputeBarrier(cmd);
  for (auto& s : systems_) {
    cmdPass(cmd, finish_, *s, 1, 0);
    ++s->step;
  }
  ++step_;
}

void GpuSimulation::cmdWriteRender(VkCommandBuffer cmd) {
  cmdComputeBarrier(cmd);
  for (auto& s : systems_) vkCmdFillBuffer(cmd, s->counters.handle(), offsetof(sio::ParticleCounters, live), 4, 0);
  cmdComputeBarrier(cmd);
  for (auto& s : systems_) cmdPass(cmd, output_, *s, s->capacity, 0);
}

void GpuSimulation::step(uint32_t steps) {
  while (steps > 0) {
    uint32_t batch = std::min<uint32_t>(steps, 256);
    context_.submitAndWait([&](VkCommandBuffer cmd) {
      for (uint32_t k = 0; k < batch; ++k) cmdStep(cmd);
    });
    steps -= batch;
  }
}

const gpu::Buffer& GpuSimulation::renderBuffer(size_t system) const { return systems_.at(system)->render; }
const gpu::Buffer& GpuSimulation::counterBuffer(size_t system) const { return systems_.at(system)->counters; }

namespace {

sio::ParticleCounters readCounters(gpu::Context& context, const gpu::Buffer& b) {
  sio::ParticleCounters c{};
  std::vector<uint8_t> bytes = gpu::readbackBuffer(context, b, sizeof(c));
  std::memcpy(&c, bytes.data(), sizeof(c));
  return c;
}

} // namespace

uint64_t GpuSimulation::liveParticles() {
  uint64_t n = 0;
  for (auto& s : systems_) n += s->capacity - readCounters(context_, s->counters).deadCount;
  return n;
}

std::vector<sio::Particle> GpuSimulation::readParticles(size_t system) {
  const System& s = *systems_.at(system);
  std::vector<uint8_t> particles =
      gpu::readbackBuffer(context_, s.particles, size_t(s.capacity) * sizeof(sio::Particle));
  std::vector<uint8_t> alive = gpu::readbackBuffer(context_, s.alive, size_t(s.capacity) * 4);
  std::vector<sio::Particle> out;
  for (uint32_t i = 0; i < s.capacity; ++i) {
    uint32_t flag;
    std::memcpy(&flag, alive.data() + size_t(i) * 4, 4);
    if (!flag) continue;
    sio::Particle p;
    std::memcpy(&p, particles.data() + size_t(i) * sizeof(p), sizeof(p));
    out.push_back(p);
  }
  return out;
}

std::vector<sio::RenderParticle> GpuSimulation::readRender() {
  std::vector<sio::RenderParticle> out;
  for (auto& s : systems_) {
    uint32_t live = std::min(readCounters(context_, s->counters).live, s->capacity);
    if (live == 0) continue;
    std::vector<uint8_t> bytes = gpu::readbackBuffer(context_, s->render, size_t(live) * sizeof(sio::RenderParticle));
    size_t at = out.size();
    out.resize(at + live);
    std::memcpy(out.data() + at, bytes.data(), bytes.size());
  }
  return out;
}

} // namespace mirage::particles
