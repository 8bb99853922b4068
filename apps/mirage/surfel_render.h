#pragma once
// `mirage bench surfels FILE`: the surfel renderer on a .mrg 'SURF' chunk or a surfel PLY
// (cmd_render_surfels.cpp).
#include <optional>
#include <string>

#include "mirage/runtime/config.h"

namespace mirage::cli {

struct SurfelRenderRequest {
  std::string input;  // .mrg with a SURF chunk, or .ply
  std::string camera; // empty: auto 3/4 view
  std::string size = "1920x1080";
  std::string device;
  std::string raster = "auto";                            // auto | compute | raster; bench: "all"
  float surfelSize = runtime::kSurfelDefaults.surfelSize; // s, pixels
  uint32_t copies = 1;                                    // instances of the cloud on a grid
  bool sharedCopies = false;      // bench: copies read one stored cloud (else each its own copy of the data)
  bool allSurfels = false;        // bench: splat all N per instance
  std::string backface = "off";   // bench: back-face culling on | off | both (both timed in one run)
  std::string discs = "oriented"; // bench: oriented | facing | both
  std::string merge = "auto";     // bench: subgroup merge in the compute splat: off | on | auto | both | all
  std::string
      order; // blue | coherent | coherent256 (default: render::kDefaultSurfelOrder); bench: a comma list or "all"
  double bandwidth = 4.8e12;      // bench: device bandwidth in B/s for the reported fraction
  int frames = 1;                 // --frames (the first is a warm-up)
  double warmupMs = 0.0;          // bench: the warm-up frame repeats for this long (GPU clock)
  std::optional<float> stereoIpd; // bench --stereo: both eyes (2W x H) per frame, compute splat only
  bool stats = false;
  bool json = false;
};

void runSurfelBench(const SurfelRenderRequest& request);

} // namespace mirage::cli
