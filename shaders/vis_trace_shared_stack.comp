#version 460
// The compute traversal with its stack in shared memory (vis_trace_compute.glsl).
#define MIRAGE_RT_SHARED_STACK
#include "vis_trace_compute.glsl"
