#pragma once
// The sampler's disc splatters side by side on one G-buffer (`mirage surfels --disc-raster all`,
// `mirage bench surfels-sampler`): per-stage GPU times from timestamps, ratios vs compute, and a
// check that every splatter gives compute's order.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mirage/core/result.h"
#include "mirage/surfels/gpu_sampler.h"

namespace mirage::cli {

// "compute", "mesh", "geometry", a comma list of them, or "all" (every splatter, compute first).
Result<std::vector<surfels::DiscRaster>> parseDiscRasterList(const std::string& text);

struct DiscRasterRun {
  surfels::DiscRaster raster = surfels::DiscRaster::Compute;
  std::string skipped;              // why it did not run (unsupported here); empty when it ran
  std::vector<gpu::PassTime> times; // per stage, summed over rounds, median over repeats
  double seconds = 0.0;             // wall time of the sampler loop (median)
  uint32_t rounds = 0;
  bool sameOrderAsFirst = true; // texels and radii equal to the first run's, bit for bit
  surfels::SampleOrder order;
  double stageMs(const std::string& name) const;
};

// Runs the sampler with `config` with every splatter in `rasters`, `repeat` rounds round-robin after
// an untimed warm-up of the first; unsupported splatters are reported as skipped.
Result<std::vector<DiscRasterRun>> compareDiscRasters(gpu::Context& ctx, const surfels::GpuGBuffer& gb,
                                                      surfels::GpuSamplerConfig config,
                                                      const std::vector<surfels::DiscRaster>& rasters, int repeat);
void printDiscRasterTable(const std::vector<DiscRasterRun>& runs);
nlohmann::json discRasterJson(const std::vector<DiscRasterRun>& runs);

} // namespace mirage::cli
