#pragma once
// The compute traversal's acceleration structure (vulkan_backend.cpp, shaders/vis_trace*.comp): an
// SAH BVH (optionally with spatial splits) built by Embree's own builder (rtcBuildBVH) over the
// flattened world-space triangles, stored as binary Aila-Laine nodes, 4-wide nodes or compressed
// 8-wide nodes (Ylitie et al. 2017) of shaderio/rays.h.
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/shaderio/rays.h"

namespace mirage::vis::detail {

struct RayBvh {
  std::vector<shaderio::RtBvhNode> nodes;         // width 2: node 0 is the root (always an inner node)
  std::vector<shaderio::RtBvh4Node> nodes4;       // width 4: the same
  std::vector<shaderio::RtBvh8Node> nodes8;       // width 8 (compressed): the same
  std::vector<shaderio::RtBvhTriangle> triangles; // leaf references, each leaf's run ends LAST
  uint32_t depth = 0;                             // deepest leaf (the root's children: 1)
  double buildSeconds = 0.0;                      // Embree build and the conversion
};

// Global IDs as triangleOffsets (instance-major); Blend and Mask materials flagged see-through.
struct RayBvhOptions {
  bool spatialSplits = false; // RTC_BUILD_QUALITY_HIGH instead of MEDIUM
  uint32_t maxLeafSize = 4;   // 1..RTC_BUILD_MAX_PRIMITIVES_PER_LEAF (32)
  uint32_t width = 2;         // children per node: 2 (RtBvhNode), 4 (RtBvh4Node) or 8 (RtBvh8Node)
};

// An empty scene gives no nodes. Width 4 limits the depth so that three pushes per level fit the
// shader's stack. Width 8 makes leaves of at most MIRAGE_RT_BVH8_LEAF_MAX triangles whatever
// maxLeafSize says (a larger leaf the builder forces at its depth limit becomes a node of leaves).
Result<RayBvh> buildRayBvh(const Scene& scene, const RayBvhOptions& options = {});

// The box of slot `slot` of an 8-wide node as the shader decodes it (origin + q * 2^e), in double
// precision: exact, so tests can check it contains the child's box.
void decodeBvh8Box(const shaderio::RtBvh8Node& node, uint32_t slot, glm::dvec3& lo, glm::dvec3& hi);

// A CPU replica of the compute shaders' traversal of the 4- and 8-wide BVHs (the same slab tests,
// child order and Moller-Trumbore test, but not the 4-wide shader's leaf postponing, which only
// reorders leaves between lanes of a subgroup; see-through triangles do not stop the ray), counting
// the work per ray: to compare ray distributions and node layouts without a GPU, and to test the
// 8-wide encoding against Embree without one.
struct CpuTraceResult {
  uint32_t triangle = MIRAGE_RT_NO_HIT; // closest opaque triangle (global ID)
  float t = 0.0f;
  uint32_t seeThrough = MIRAGE_RT_NO_HIT; // nearest see-through triangle in front of it
  uint32_t nodes = 0;                     // inner nodes visited (boxes tested: width x nodes)
  uint32_t triangleTests = 0;
};
CpuTraceResult cpuTrace(const RayBvh& bvh, glm::vec3 origin, glm::vec3 dir, float tnear, float tfar);

} // namespace mirage::vis::detail
