#version 460
// Lean compute rasterizer (docs/render.md, "Lean raster"): the clusters the selection put on the
// compute backend's down list (leanRasterCluster), each triangle by the per-thread 32-bit walk
// alone. Dispatched right after the general kernels with no barrier between them: all of them
// only take 64-bit atomic maxima of the visibility buffer. The body is cluster_raster.glsl.
#extension GL_EXT_shader_atomic_int64 : require
#define MIRAGE_RASTER_LEAN 1
#include "cluster_raster.glsl"
