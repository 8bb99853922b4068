// GPU side of `mirage bench particles`: timestamp queries around each timed step.
#include <algorithm>
#include <chrono>
#include <numeric>

#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/particles/bench.h"
#include "mirage/particles/gpu_simulation.h"
#include "mirage/particles/simulation.h"

namespace mirage::particles {

Result<BenchResult> benchGpu(gpu::Context& context, const EffectFile& effect, const BenchOptions& o) {
  VkPhysicalDeviceMemoryProperties memory{};
  vkGetPhysicalDeviceMemoryProperties(context.physicalDevice(), &memory);
  uint64_t heap = 0;
  for (uint32_t i = 0; i < memory.memoryHeapCount; ++i)
    if (memory.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      heap = std::max(heap, memory.memoryHeaps[i].size);
  if (Status s = checkParticleMemory(o.count, kGpuBytesPerParticle, heap / 2, "device memory"); !s) return s.error();
  EffectFile scaled = scaleEffect(effect, o.count);
  BenchResult r;
  GpuSimulation sim(context, scaled, o.dt);
  r.fillSteps = fillSteps(scaled, o.dt);
  sim.step(uint32_t(r.fillSteps));
  gpu::GpuTimer timer(context, 2);
  std::vector<double> ms;
  for (uint32_t i = 0; i < o.steps; ++i) {
    context.submitAndWait([&](VkCommandBuffer cmd) {
      timer.cmdReset(cmd);
      uint32_t slot = timer.cmdBegin(cmd, "step");
      sim.cmdStep(cmd);
      timer.cmdEnd(cmd, slot);
    });
    for (const gpu::PassTime& t : timer.read()) ms.push_back(t.milliseconds);
  }
  r.live = sim.liveParticles();
  context.submitAndWait([&](VkCommandBuffer cmd) {
    timer.cmdReset(cmd);
    uint32_t slot = timer.cmdBegin(cmd, "output");
    sim.cmdWriteRender(cmd);
    timer.cmdEnd(cmd, slot);
  });
  for (const gpu::PassTime& t : timer.read()) r.outputMs = t.milliseconds;
  setStepTimes(ms, r);
  return r;
}

} // namespace mirage::particles
