#pragma once
// The host's GVS++ exploration rays (gvs.cpp): adaptive border sampling (ABS) and reverse sampling
// (RS) rays of an ExploreRaySource, slot by slot, with the formulas of shaderio/gvs_explore.h that
// the Vulkan backend's shaders use too (traceExploreRays), so both make the same rays.
#include <span>

#include <glm/glm.hpp>

#include "mirage/core/scene.h"
#include "mirage/visibility/ray_backend.h"

namespace mirage::vis::detail {

// Every slot of the source (items × raysPerItem): the ray, or tfar = -1 where the slot is skipped
// (a degenerate border, a zero direction, an origin in the occluder's shadow, an untraceable ray).
// `targets` (ABS only, else empty) gets each ray's border point. Runs on all cores.
void makeExploreRays(const Scene& scene, std::span<const uint64_t> offsets, const ExploreRaySource& source,
                     std::span<Ray> rays, std::span<glm::vec3> targets);

// The ray of one slot (as makeExploreRays makes it, but never skipped), to rebuild a discovering
// ray: its origin seeds border sampling.
Ray exploreRay(const Scene& scene, std::span<const uint64_t> offsets, const ExploreRaySource& source, size_t slot);

} // namespace mirage::vis::detail
