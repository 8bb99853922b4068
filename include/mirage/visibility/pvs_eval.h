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
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/visibility/gvs.h"
#include "mirage/visibility/ray_backend.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

struct EvalConfig {
  uint32_t resolution = 1000;    // square views, one primary ray per pixel (the seed: 1024²)
  uint32_t haltonViewpoints = 4; // viewpoints inside the cell besides its corners
  // Each viewpoint renders 6 views of 90° along a randomly rotated cube frame, so errors are
  // measured over the whole view sphere, not only around one viewing direction.
  uint64_t seed = 7;
  // Called after every view rendered (views done, views in all).
  std::function<void(uint32_t, uint32_t)> progress;
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

// The RASTER baseline (after Nirenstein & Blake 2004): triangle-ID cube maps (6 axis-aligned 90°
// faces of resolution² pixels) rendered at Halton points inside the cell (on it, for a Rect); the
// union of the IDs seen is the PVS. Each pixel is one primary ray through its centre, traced by
// the backend: the same point samples a rasterizer takes at pixel centres, with see-through
// triangles in front of the nearest opaque one recorded as a blended ID pass would draw them.
struct RasterConfig {
  uint32_t resolution = 256;
  // Cube maps rendered: enough to spend `pixelBudget` pixels (at least one), or `points` if the
  // budget is 0.
  uint64_t pixelBudget = 0;
  uint32_t points = 16;
  uint64_t seed = 3;
};
uint32_t rasterPoints(const RasterConfig& config);
// Pixels traced are reported as rays (stats.rays) so RASTER sits on the same axis as GVS++ and RAND.
// Checkpoints as in computeCellPvs, taken after each cube map.
CellPvs rasterPvs(RayBackend& backend, const ViewCell& cell, const RasterConfig& config, const BakeOptions& options);

} // namespace mirage::vis
