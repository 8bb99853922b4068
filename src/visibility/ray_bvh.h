#pragma once
// The compute traversal's acceleration structure (vulkan_backend.cpp, shaders/vis_trace.comp): a
// binary SAH BVH (optionally with spatial splits) built by Embree's own builder (rtcBuildBVH) over
// the flattened world-space triangles, stored in the Aila-Laine layout of shaderio/rays.h.
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/shaderio/rays.h"

namespace mirage::vis::detail {

struct RayBvh {
  std::vector<shaderio::RtBvhNode> nodes;         // node 0 is the root (always an inner node)
  std::vector<shaderio::RtBvhTriangle> triangles; // leaf references, each leaf's run ends LAST
  uint32_t depth = 0;                             // deepest leaf (the root's children: 1)
  double buildSeconds = 0.0;                      // Embree build and the conversion
};

// Global IDs as triangleOffsets (instance-major); Blend and Mask materials flagged see-through.
// An empty scene gives no nodes. `spatialSplits`: RTC_BUILD_QUALITY_HIGH instead of MEDIUM.
Result<RayBvh> buildRayBvh(const Scene& scene, bool spatialSplits = false);

} // namespace mirage::vis::detail
