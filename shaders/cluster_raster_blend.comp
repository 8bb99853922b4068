#version 460
// Compute rasterizer of blended clusters (after the resolve): the opaque rasterizer's coverage and
// depth (cluster_raster.glsl), each fragment in front of the opaque depth pushed onto its pixel's
// transparency list instead of an atomicMax. Needs no 64-bit atomics, so it serves every backend.
// Draws the compute blend list (all blend clusters, or the small-triangle ones beside the hardware
// blend raster, cluster_blend.*).
#define MIRAGE_RASTER_BLEND 1
#define MIRAGE_BLEND_LISTS 1 // push.rasterList names the compute blend list
#include "cluster_raster.glsl"
