#pragma once
// The GPU progressive sampler (Brandt et al. 2019, as in PADrend): rounds of incremental Voronoi
// splatting, farthest texel per cell by 64-bit atomicMax, candidate filtering, Poisson-disc
// conflict resolution, GPU radix sort by decreasing radius and append, until the requested count.
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/surfels/capture.h"

namespace mirage::surfels {

struct GpuSamplerConfig {
  uint32_t count = 100000;  // surfels wanted (fewer when the G-buffer runs out of texels)
  float threshold = 0.75f;  // keep a cell's farthest texel when >= threshold × the round's maximum
                            // (PADrend's 0.75: lower = fewer rounds, looser blue noise)
  bool bitonicSort = false; // the old bitonic candidate sort instead of the radix sort (same order; for timing)
};

struct GpuSamplerResult {
  SampleOrder order;                // compact texel indices into gbuffer.texels; radii non-increasing
  uint32_t rounds = 0;              // sampler rounds (two submits each)
  double seconds = 0.0;             // wall time of the loop, submits and waits included
  std::vector<gpu::PassTime> times; // GPU time per stage, summed over rounds
};

// Requires 64-bit buffer atomics (lavapipe and the H200 have them). Deterministic for the same
// G-buffer: every atomic's winner is a total order on (distance, index) and candidates are sorted.
Result<GpuSamplerResult> sampleOnGpu(gpu::Context& context, const GpuGBuffer& gbuffer, const GpuSamplerConfig& config);

} // namespace mirage::surfels
