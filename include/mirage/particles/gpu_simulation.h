#pragma once
// The GPU particle simulation (docs/particles.md): per system a pool in device memory (Particle
// slots, alive flags, a dead-slot stack and counters) stepped by three compute passes
// (shaders/particles_update, _emit, _finish.comp) that evaluate the CPU's formulas
// (shaderio/particles.h). The host computes each step's emission (emitRequest) as the CPU pool
// does, and the same spawn index keys the same random numbers, so particle i of a system lives the
// same life on both, to float precision; slots differ (the dead stack fills in any order).
#include <cstdint>
#include <memory>
#include <vector>

#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/gpu/vk.h"
#include "mirage/particles/effect.h"
#include "mirage/shaderio/particles.h"

namespace mirage::gpu {
class Context;
}

namespace mirage::particles {

class GpuSimulation {
public:
  // Pools of each system's max particles, every slot free; prewarm steps run here (on the GPU).
  GpuSimulation(gpu::Context& context, const EffectFile& effect, float dt);
  ~GpuSimulation();
  GpuSimulation(const GpuSimulation&) = delete;
  GpuSimulation& operator=(const GpuSimulation&) = delete;

  // Records one step of every system (update, emit, finish with barriers between); the caller
  // submits. Barriers: waits for earlier compute and transfer writes. With writeRender, the step
  // also leaves the render records and their count, as cmdWriteRender after it would (in another
  // order): the update appends each survivor's, the emission each spawn's, so a frame that steps
  // once and draws reads each particle once.
  void cmdStep(VkCommandBuffer cmd, bool writeRender = false);
  // Records the output pass: each system's RenderParticle records at the start of renderBuffer(i)
  // and their count in counters field `live` (counterBuffer(i), offset 12: an indirect draw's
  // instance count). The caller adds a barrier before reading them.
  void cmdWriteRender(VkCommandBuffer cmd);
  // Convenience: `steps` steps in one submission, waiting for it.
  void step(uint32_t steps = 1);

  size_t systemCount() const { return systems_.size(); }
  const gpu::Buffer& renderBuffer(size_t system) const;
  const gpu::Buffer& counterBuffer(size_t system) const;
  // Read back (blocking): live particles of every system, their states, their render records
  // (after cmdWriteRender, pool after pool).
  uint64_t liveParticles();
  std::vector<shaderio::Particle> readParticles(size_t system);
  std::vector<shaderio::RenderParticle> readRender();
  uint64_t stepsTaken() const { return step_; }

private:
  struct System;
  void cmdPass(VkCommandBuffer cmd, VkPipeline pipeline, const System& s, uint32_t threads, uint32_t emit,
               bool writeRender = false);
  gpu::Context& context_;
  float dt_;
  uint64_t step_ = 0;
  gpu::Unique<VkPipelineLayout> layout_;
  gpu::Unique<VkPipeline> update_, emit_, finish_, output_;
  std::vector<std::unique_ptr<System>> systems_;
};

} // namespace mirage::particles

namespace mirage::particles {
struct BenchOptions;
struct BenchResult;
// `mirage bench particles --sim gpu`: the effect scaled and filled as benchCpu does, then each
// timed step in its own submission between timestamp queries (GPU time of the three passes).
// Error: more particles than half the largest device-local heap holds.
Result<BenchResult> benchGpu(gpu::Context& context, const EffectFile& effect, const BenchOptions& options);
} // namespace mirage::particles
