#version 460
// Hybrid backend, hardware list through indirect draws: the fragment writes the compute
// rasterizer's encoding, atomicMax(reverse-Z depth bits << 32 | packed id), into the same 64-bit
// buffer, so both paths resolve depth and ties identically with no merge pass. No depth attachment:
// facing is decided here per instance, and early depth writes would let dropped back faces occlude.
#extension GL_EXT_multiview : require
#define MIRAGE_VIEW_INDEX gl_ViewIndex // 0 unless the pipeline draws stereo by multiview
#extension GL_EXT_shader_atomic_int64 : require
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) flat in uvec2 inId;

#include "cluster_vis_atomic.glsl"
