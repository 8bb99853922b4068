// Mixed scenes (docs/render.md, "Mixed scenes"): what the cluster renderer's resolve needs to shade
// the surfel pixels of the shared 64-bit visibility buffer, i.e. the surfel renderer's arrays.
#ifndef MIRAGE_SHADERIO_SURFEL_LINK_H
#define MIRAGE_SHADERIO_SURFEL_LINK_H

#include "mirage/shaderio/surfel_render.h"

#ifdef __cplusplus
namespace mirage::shaderio {
#endif

// Visibility ids with this bit set are surfels ((1 + splat index) | tag); cluster ids,
// ((visible entry + 1) << 7) | triangle, stay below 2^29 (kMaxVisibleClusters = 2^22 entries).
#define MIRAGE_SURFEL_ID_TAG 0x80000000u

struct ClusterSurfelLink {
  uint64_t stateAddress;     // SurfelInstanceState[] (this frame's k, first ids)
  uint64_t instanceAddress;  // SurfelRenderInstance[]
  uint64_t cloudAddress;     // SurfelRenderCloud[]
  uint64_t positionAddress;  // uvec2[] quantized positions
  uint64_t attributeAddress; // uvec2[] (octahedral normal, RGBA8)
  uint64_t materialAddress;  // GpuMaterial[] of the clouds
  uint instanceCount;        // surfel instances
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(ClusterSurfelLink) == 56, "ClusterSurfelLink layout");
} // namespace mirage::shaderio
#endif

#endif
