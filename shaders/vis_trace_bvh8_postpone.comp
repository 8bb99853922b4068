#version 460
// The compute traversal over compressed 8-wide BVH nodes with triangle postponing
// (vis_trace_bvh8.glsl).
#define MIRAGE_RT_BVH8
#define MIRAGE_RT_BVH8_POSTPONE
#include "vis_trace_compute.glsl"
