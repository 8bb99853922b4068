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
  std::vector<shaderio::RtBvhNode> nodes;         // width 2: node 0 is the root (always an inner node)
  std::vector<shaderio::RtBvh4Node> nodes4;       // width 4: the same
  std::vector<shaderio::RtBvhTriangle> triangles; // leaf references, each leaf's run ends LAST
  uint32_t depth = 0;                             // deepest leaf (the root's children: 1)
  double buildSeconds = 0.0;                      // Embree build and the conversion
};

// Global IDs as triangleOffsets (instance-major); Blend and Mask materials flagged see-through.
struct RayBvhOptions {
  bool spatialSplits = false; // RTC_BUILD_QUALITY_HIGH instead of MEDIUM
  uint32_t maxLeafSize = 4;   // 1..RTC_BUILD_MAX_PRIMITIVES_PER_LEAF (32)
  uint32_t width = 2;         // children per node: 2 (RtBvhNode) or 4 (RtBvh4Node)
};

// An empty scene gives no nodes. Width 4 limits the depth so that three pushes per level fit the
// shader's stack.
Result<RayBvh> buildRayBvh(const Scene& scene, const RayBvhOptions& options = {});

} // namespace mirage::vis::detail
