#pragma once
// `mirage surfels --per-mesh` on every rank of a World: one work unit per mesh with triangles (its
// object-space G-buffer capture and GPU sampling), each rank on its own Vulkan device, gathered on
// rank 0 into the clouds the single-process bake gives, bit for bit (the capture and the sampler
// are deterministic). Library mirage_bake_gpu: the GPU side of mirage_bake. docs/bake.md.
#include <string>
#include <vector>

#include "mirage/bake/lod_bake.h" // BakeRun, journalPath
#include "mirage/bake/scheduler.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/surfel_io.h"

namespace mirage::bake {

struct SurfelBakeConfig {
  surfels::CaptureConfig capture;    // views, layers, resolution
  surfels::GpuSamplerConfig sampler; // count, threshold, splatter (its progress callback is not used)
};

// A mesh's cloud and what the report says of it.
struct MeshCloud {
  surfels::MeshSurfels surfels;
  uint64_t texels = 0;   // G-buffer texels sampled
  double rho = 0.0;      // the whole cloud's normalized Poisson radius (measurePrefix)
  double coverage = 0.0; // and coverage
  double seconds = 0.0;  // capture and sampling on the rank that baked it
};

// The scene reduced to mesh `index` alone, in its object space (identity instance), with only the
// material and base colour texture it uses: what a mesh's cloud is sampled from.
Scene meshScene(const Scene& scene, uint32_t index);

// The device a rank opens when none is named: among the visible devices of the best kind (discrete,
// else integrated, else CPU), the one at the local rank (modulo their count); "" in a world of one
// or with MIRAGE_DEVICE set (gpu::Context's own choice).
std::string deviceForRank(const World& world);

// Collective: every rank passes its own open context and the same config; only rank 0 needs the
// scene (each mesh is sent to the rank that samples it). Rank 0 gets one MeshCloud per mesh with
// triangles, in mesh order; the others an empty vector. Error: a scene without triangles (rank 0).
Result<std::vector<MeshCloud>> bakeSurfelsPerMesh(const World& world, gpu::Context& context, const Scene& scene,
                                                  const SurfelBakeConfig& config, const BakeRun& run,
                                                  ScheduleReport* report = nullptr, const UnitProgress& progress = {});

} // namespace mirage::bake
