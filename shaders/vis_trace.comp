#version 460
// The compute traversal with its stack in per-thread local memory (vis_trace_compute.glsl).
#include "vis_trace_compute.glsl"
