#version 460
// The compute traversal over 4-wide BVH nodes (RtBvh4Node), stack in local memory
// (vis_trace_compute.glsl).
#define MIRAGE_RT_BVH4
#include "vis_trace_compute.glsl"
