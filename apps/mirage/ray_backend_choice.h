#pragma once
// Which ray backend a visibility command runs on (--backend auto|embree|vulkan|compute[-VARIANT],
// --device).
#include <memory>
#include <string>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/visibility/ray_backend.h"

namespace mirage::cli {

struct RayBackendChoice {
  // auto: Vulkan on a GPU, Embree on a CPU driver; vulkan: the traversal Traversal::Auto picks
  // (compute where the ray-tracing pipeline is missing or emulated); compute: the Vulkan compute
  // traversal; compute-VARIANT: one of its variants (kComputeVariants).
  std::string backend = "auto";
  std::string geometry = "auto";
  std::string device;
  bool packets = true; // Embree: packets of 16 for coherent traces
  // Vulkan: GVS++ border and reverse rays made on the host and uploaded, instead of in the shader
  // that traces them (VulkanRayOptions::exploreOnDevice), to compare the two.
  bool hostExploration = false;
};

// The Vulkan compute traversal's variants by name: --backend values and `bench rays` labels, so
// the fastest variant a bench run reports can be named for a bake.
struct ComputeVariant {
  const char* name;
  bool persistentThreads;
  bool sharedStack;
  uint32_t bvhWidth;
  bool postponeTriangles = false;
};
inline constexpr ComputeVariant kComputeVariants[] = {
    {"compute", false, false, 4}, // the default: 4-wide BVH (fastest on the H200, docs/visibility.md)
    {"compute-persistent", true, false, 4},
    {"compute-bvh2", false, false, 2},
    {"compute-bvh2-persistent", true, false, 2},
    {"compute-bvh2-shared-stack", false, true, 2},
    {"compute-bvh8", false, false, 8}, // compressed 8-wide nodes (Ylitie et al. 2017)
    {"compute-bvh8-persistent", true, false, 8},
    {"compute-bvh8-postpone", false, false, 8, true},
};
const ComputeVariant* findComputeVariant(const std::string& name);

struct OpenedRayBackend {
  std::unique_ptr<gpu::Context> context; // declared first: outlives the backend
  std::unique_ptr<vis::RayBackend> backend;
  double buildSeconds = 0.0;
};

// The option values are checked here too (one-line errors).
Status checkRayBackendChoice(const RayBackendChoice& choice);
Result<OpenedRayBackend> openRayBackend(const RayBackendChoice& choice, const Scene& scene);
// Opens the backend named `backend` ("embree", "vulkan" or a compute variant); `context` is reused
// when set.
Result<std::unique_ptr<vis::RayBackend>> openNamedRayBackend(const std::string& backend, const std::string& geometry,
                                                             bool packets, const Scene& scene, gpu::Context* context,
                                                             bool hostExploration = false);

} // namespace mirage::cli
