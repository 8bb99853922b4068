#pragma once
// G-buffer capture for Blue Surfels: the scene rendered from V orthographic directions on a
// Fibonacci sphere into layered position/normal/colour targets (multiview where the device allows,
// several passes otherwise). The positions stay on the GPU for the progressive sampler; the valid
// texels come back to the CPU for the reference sampler and the metrics.
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/surfels/surfel.h"

namespace mirage::surfels {

struct CaptureConfig {
  uint32_t resolution = 1024;   // G-buffer width = height (texels); limited by the device's 2D image size
  uint32_t views = 16;          // orthographic directions on a Fibonacci sphere (PADrend's default)
  uint32_t maxViewsPerPass = 0; // 0: the device's multiview limit; 1 forces one pass per view (tests)
  uint32_t layers = 1;          // depth-peeling layers per direction: layer i sees what lies behind layer i-1
};

struct GpuGBuffer {
  gpu::Buffer positions;                   // vec4 per global texel on the GPU (w = 1 where valid)
  std::vector<shaderio::SurfelView> views; // per G-buffer view (layer-major: layer * directions + direction)
  GBufferTexels texels;                    // valid texels on the CPU
  uint32_t passes = 0;                     // render passes used (1 per layer with enough multiview views)
  std::vector<gpu::PassTime> times;        // GPU times: "capture" (rasterization), "copy"
};

// Unit directions towards the camera, evenly spread (golden-angle spiral); deterministic.
std::vector<glm::vec3> fibonacciDirections(uint32_t count);

// Errors: a scene without triangles, resolution or view count outside what the device supports.
Result<GpuGBuffer> captureGBuffer(gpu::Context& context, const Scene& scene, const CaptureConfig& config);

struct ScanPoints; // point_cloud.h

// A point cloud captured into the same G-buffers: every point splats an oriented disc (radius its
// 16th-neighbour distance, at most kMaxDiscSpacingRatio × the median one) into every view by a
// compute pass with a 64-bit atomicMin depth test; each texel gets the nearest disc's plane point,
// normal (towards the viewer) and colour. The texel areas, the GPU sampler and the metrics then
// run as for a mesh. Discs facing away from a view are skipped when the scan's normals are its own
// (oriented); estimated normals are splatted two-sided. Deterministic (ties go to the smaller
// point index). Depth peeling (layers > 1) as in the mesh capture: layer i keeps disc points more
// than two median disc radii behind layer i−1's; it needs oriented normals. Times: "splat",
// "resolve", "copy" (summed over layers). Errors: as captureGBuffer; layers > 1 without the scan's
// own normals.
Result<GpuGBuffer> capturePointCloud(gpu::Context& context, const ScanPoints& points, const CaptureConfig& config);

// Disc radii are clamped to this many median spacings: an isolated outlier's 16th neighbour can be
// far away, and its disc would paint a large flat patch over the G-buffer.
constexpr float kMaxDiscSpacingRatio = 4.0f;

} // namespace mirage::surfels
