#version 460
// Compute rasterizer of alpha-masked clusters, dispatched over the same list as the opaque one
// (only for scenes with MASK materials): each pixel sample passes the alpha test (cluster_alpha.glsl)
// before its atomicMax. The body is cluster_raster.glsl.
#extension GL_EXT_shader_atomic_int64 : require
#define MIRAGE_RASTER_MASK 1
#include "cluster_raster.glsl"
