#version 460
// Compute rasterizer of opaque clusters (masked ones are skipped: cluster_raster_mask.comp draws
// them); the body is cluster_raster.glsl.
#extension GL_EXT_shader_atomic_int64 : require
#include "cluster_raster.glsl"
