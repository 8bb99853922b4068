// CPU side of `mirage bench particles`: wall time of whole steps (all pools, all threads).
#include "mirage/particles/bench.h"

#include <algorithm>
#include <chrono>
#include <numeric>
#include <vector>

#include <fmt/format.h>
#include <tbb/info.h>
#include <unistd.h>

#include "mirage/particles/simulation.h"

namespace mirage::particles {

namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

} // namespace

Status checkParticleMemory(uint64_t count, uint64_t bytesPerParticle, uint64_t available, const char* where) {
  uint64_t need = count * bytesPerParticle;
  if (need > available)
    return Error{fmt::format("{} particles need {:.1f} GB, more than the {:.1f} GB of {} a bench may use", count,
                             double(need) / 1e9, double(available) / 1e9, where)};
  return Ok{};
}

void setStepTimes(std::vector<double> ms, BenchResult& r) {
  if (ms.empty()) return;
  r.meanStepMs = std::accumulate(ms.begin(), ms.end(), 0.0) / double(ms.size());
  std::sort(ms.begin(), ms.end());
  r.medianStepMs = ms[ms.size() / 2];
  r.minStepMs = ms.front();
}

Result<BenchResult> benchCpu(const EffectFile& effect, const BenchOptions& o) {
  uint64_t physical = uint64_t(sysconf(_SC_PHYS_PAGES)) * uint64_t(sysconf(_SC_PAGE_SIZE));
  if (Status s = checkParticleMemory(o.count, kCpuBytesPerParticle, physical / 2, "host memory"); !s) return s.error();
  EffectFile scaled = scaleEffect(effect, o.count);
  BenchResult r;
  r.threads = uint32_t(tbb::info::default_concurrency());
  Simulation sim = makeSimulation(scaled, o.dt);
  r.fillSteps = fillSteps(scaled, o.dt);
  for (uint64_t i = 0; i < r.fillSteps; ++i) step(sim);
  std::vector<double> ms(o.steps);
  for (double& m : ms) {
    auto t0 = std::chrono::steady_clock::now();
    step(sim);
    m = msSince(t0);
  }
  r.live = liveParticles(sim);
  std::vector<shaderio::RenderParticle> out(r.live);
  writeRenderParticles(sim, out); // untimed: the first write also faults the pages in
  auto t0 = std::chrono::steady_clock::now();
  writeRenderParticles(sim, out);
  r.outputMs = msSince(t0);
  setStepTimes(ms, r);
  return r;
}

} // namespace mirage::particles
