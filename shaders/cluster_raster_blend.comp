#version 460
// Compute rasterizer of blended clusters (after the resolve): the opaque rasterizer's coverage and
// depth (cluster_raster.glsl), each fragment in front of the opaque depth pushed onto its pixel's
// transparency list instead of an atomicMax. Needs no 64-bit atomics, so it serves every backend.
#define MIRAGE_RASTER_BLEND 1
#include "cluster_raster.glsl"
