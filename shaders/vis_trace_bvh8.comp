#version 460
// The compute traversal over compressed 8-wide BVH nodes (RtBvh8Node, vis_trace_bvh8.glsl).
#define MIRAGE_RT_BVH8
#include "vis_trace_compute.glsl"
