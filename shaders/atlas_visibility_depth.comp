#version 460
// Compute visibility's depth raster of opaque clusters (docs/stream.md, "Visibility stage"):
// cluster_raster.comp with the global queue: a triangle whose box exceeds
// ClusterFrame::blendQueuePixels is not walked by its cluster's workgroup but queued, and its tiles
// are spread over many workgroups by atlas_visibility_depth_queue.comp (screen-filling walls and
// floors would otherwise keep one workgroup walking while the GPU idles).
#extension GL_EXT_shader_atomic_int64 : require
#define MIRAGE_RASTER_DEPTH_QUEUE 1
#include "cluster_raster.glsl"
