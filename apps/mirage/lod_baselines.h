#pragma once
// The seed's comparison for `mirage bench render scene.mrg --baselines`: the same scene and camera
// drawn by the forward renderer at full resolution (brute force) and with a discrete LOD chain
// chosen per instance by distance, beside the cluster-LOD renderer's numbers.
#include <nlohmann/json.hpp>

#include "mirage/gpu/context.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"

namespace mirage::cli {

struct BaselineResult {
  std::string name;            // "brute-force" | "discrete-lod"
  double frameMs = 0.0;        // median GPU frame time
  uint64_t triangles = 0;      // drawn per frame
  uint32_t chainLevels = 0;    // discrete-lod: levels in the chain of the first mesh
  std::vector<uint32_t> usage; // discrete-lod: instances per chain level (first mesh's chain)
};

// Renders both baselines for `settings.camera` (frames: the first is a warm-up). tau is the LOD
// renderer's pixel threshold: the discrete chain gives each instance its coarsest level whose
// object-space error, projected at the instance's nearest bounding-sphere distance, is <= tau.
Result<std::vector<BaselineResult>> renderLodBaselines(gpu::Context& context, const lod::LodAsset& asset,
                                                       const render::RenderSettings& settings, float tau, int frames);

} // namespace mirage::cli
