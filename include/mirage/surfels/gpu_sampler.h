#pragma once
// The GPU progressive sampler (Brandt et al. 2019, as in PADrend): rounds of incremental Voronoi
// splatting, farthest texel per cell by 64-bit atomicMax, candidate filtering, Poisson-disc
// conflict resolution, GPU radix sort by decreasing radius and append, until the requested count.
#include <functional>
#include <string_view>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/surfels/capture.h"

namespace mirage::surfels {

// Who splats the Voronoi and Poisson discs (the voronoi and conflicts stages). All apply the same
// 64-bit atomics on the same keys to the same texels, so the sample order is bit-identical.
enum class DiscRaster {
  Compute,   // compute splatter: 8×8-thread tiles of each disc's bounding square per view
  Mesh,      // mesh shader: one quad per (disc, view); the fragment shader does the atomic
  Geometry,  // geometry shader: one point per (disc, view) expanded to that quad; same fragment shader
  MeshDepth, // Voronoi by the depth test (mesh quads into per-view layers, depth = distance, an id
             // attachment, converted back to the cells); conflicts as Mesh
};
const char* toString(DiscRaster raster);
Result<DiscRaster> parseDiscRaster(std::string_view text); // "compute", "mesh", "geometry" or "mesh-depth"
// Empty when `context` can run `raster` (on `views` G-buffer views; 0: any count); otherwise why not.
std::string discRasterUnsupported(const gpu::Context& context, DiscRaster raster, uint32_t views = 0);

struct GpuSamplerConfig {
  uint32_t count = 100000;  // surfels wanted (fewer when the G-buffer runs out of texels)
  float threshold = 0.75f;  // keep a cell's farthest texel when >= threshold × the round's maximum
                            // (PADrend's 0.75: lower = fewer rounds, looser blue noise)
  bool bitonicSort = false; // the old bitonic candidate sort instead of the radix sort (same order; for timing)
  DiscRaster discRaster = DiscRaster::Compute; // fastest on lavapipe and (12-16x) on the H200: docs/surfels.md
  // Called after every round with the samples so far (capped at count) and count: a progress bar.
  std::function<void(uint32_t samples, uint32_t count, uint32_t rounds)> progress;
};

struct GpuSamplerResult {
  SampleOrder order;                // compact texel indices into gbuffer.texels; radii non-increasing
  uint32_t rounds = 0;              // sampler rounds (two submits each)
  double seconds = 0.0;             // wall time of the loop, submits and waits included
  std::vector<gpu::PassTime> times; // GPU time per stage, summed over rounds
};

// Requires 64-bit buffer atomics (lavapipe and the H200 have them). Deterministic for the same
// G-buffer: every atomic's winner is a total order on (distance, index) and candidates are sorted.
// Bounded: every round appends at least one sample (at most min(count, texels) rounds); a round that
// appends none is an error, as are non-finite texel positions (checked before any GPU work).
Result<GpuSamplerResult> sampleOnGpu(gpu::Context& context, const GpuGBuffer& gbuffer, const GpuSamplerConfig& config);

} // namespace mirage::surfels
