#pragma once
// Pixel error of a PVS, as in the seed: from viewpoints in the cell, render the full scene and the
// PVS-only scene into triangle-ID buffers and count the pixels that differ.
//
// One trace per pixel suffices: if the full scene's visible triangle at a pixel is in the PVS, the
// PVS-only scene shows the same triangle there (removing other triangles cannot bring anything
// nearer); if it is not, the PVS-only scene shows something else. So a pixel differs exactly when
// a triangle the full render sees there (including see-through ones in front) is missing from the
// PVS (kHitMissing), which the backend reports during the full-scene trace. Those pixels are then
// traced once more in the scene reduced to the PVS: where that shows a surface at the same depth
// (an exactly coplanar duplicate or a shared edge, whose tie the two traversals may break
// differently) the rendered images agree, and the pixel is not counted.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/visibility/ray_backend.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

struct EvalConfig {
  uint32_t resolution = 1000;    // square views, one primary ray per pixel (the seed: 1024²)
  uint32_t haltonViewpoints = 4; // viewpoints inside the cell besides its corners
  // Each viewpoint renders 6 views of 90° along a randomly rotated cube frame, so errors are
  // measured over the whole view sphere, not only around one viewing direction.
  uint64_t seed = 7;
};

struct PixelError {
  uint32_t views = 0;
  uint64_t pixelsPerView = 0;
  double averageWrong = 0.0;  // wrong pixels per view, mean over views
  uint64_t maxWrong = 0;      // wrong pixels in the worst view
  uint64_t regions = 0;       // 4-connected regions of wrong pixels, summed over views
  uint64_t largestRegion = 0; // pixels of the largest region in any view
  double averageFraction() const { return pixelsPerView ? averageWrong / double(pixelsPerView) : 0.0; }
};

// Cell corners, then Halton points inside the cell (on it, for a Rect).
std::vector<glm::vec3> evaluationViewpoints(const ViewCell& cell, const EvalConfig& config);

PixelError evaluatePvs(RayBackend& backend, const ViewCell& cell, const TriangleSet& pvs, const EvalConfig& config);

} // namespace mirage::vis
