#pragma once
// Measurements behind `mirage bench particles` (docs/particles.md): an effect scaled to `count`
// particles (scaleEffect), filled (fillSteps), then `steps` timed steps. CPU: wall time per step;
// GPU: timestamp queries around each step's passes (gpu_simulation.h).
#include <cstdint>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/particles/effect.h"
#include "mirage/shaderio/particles.h"

namespace mirage::particles {

struct BenchOptions {
  uint64_t count = 1000000; // particles the scaled effect holds
  uint32_t steps = 100;     // timed steps
  float dt = 1.0f / 60.0f;
};

struct BenchResult {
  uint64_t live = 0;         // live particles after the timed steps
  uint64_t fillSteps = 0;    // untimed steps that filled the pools
  double medianStepMs = 0.0; // per step
  double meanStepMs = 0.0;
  double minStepMs = 0.0;
  double outputMs = 0.0; // one writeRenderParticles (CPU) / output pass (GPU) after the run
  uint32_t threads = 0;  // CPU: worker threads available to oneTBB
};

// Bytes a pool needs per particle: CPU (state, death list, render record), GPU (state, alive flag,
// dead stack, render record).
constexpr uint64_t kCpuBytesPerParticle = sizeof(shaderio::Particle) + 4 + sizeof(shaderio::RenderParticle);
constexpr uint64_t kGpuBytesPerParticle = sizeof(shaderio::Particle) + 8 + sizeof(shaderio::RenderParticle);
// An error when `count` particles at `bytesPerParticle` exceed `available` bytes (`where` names
// the memory): a bench of an impossible count stops with one line instead of being killed.
Status checkParticleMemory(uint64_t count, uint64_t bytesPerParticle, uint64_t available, const char* where);

// Mean, median and minimum of the timed steps' milliseconds into r (nothing when none were timed).
void setStepTimes(std::vector<double> stepMs, BenchResult& r);

// Error: more particles than half the machine's physical memory holds.
Result<BenchResult> benchCpu(const EffectFile& effect, const BenchOptions& options);

} // namespace mirage::particles
