#pragma once
// Pieces the mesh capture (capture.cpp) and the point-cloud capture (point_capture.cpp) share: the
// orthographic views, the readback-to-texels compaction and the deduplicated texel areas. Private
// to mirage_surfels.
#include <vector>

#include "mirage/shaderio/surfels.h"
#include "mirage/surfels/surfel.h"

namespace mirage::surfels::detail {

// Orthographic world -> clip for a camera on direction d around the sphere (c, r).
shaderio::SurfelView makeView(glm::vec3 d, glm::vec3 c, float r);

// Directions (layer-major) and views of a capture with t.viewCount / t.layers directions around
// (t.center, t.sphereRadius); fills t.directions, returns one view per G-buffer view.
std::vector<shaderio::SurfelView> captureViews(GBufferTexels& t, uint32_t directions);

// The valid texels (w >= 0.5) of `total` read-back texels, in global index order: position from
// pos4 (vec4), unit normal from nrm (half-float xyzw), colour from col (RGBA8).
void compactTexels(GBufferTexels& t, const float* pos4, const uint16_t* nrm, const uint32_t* col, size_t total);

// Area of each texel's surface patch, deduplicated across views (docs/surfels.md "Sampled area").
void computeAreas(GBufferTexels& t, const std::vector<shaderio::SurfelView>& views, const float* pos4);

} // namespace mirage::surfels::detail
