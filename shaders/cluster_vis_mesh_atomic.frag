#version 460
// Hybrid backend, hardware list through mesh shaders: as cluster_vis_atomic.frag, the id arriving per primitive.
#extension GL_EXT_multiview : require
#define MIRAGE_VIEW_INDEX gl_ViewIndex // 0 unless the pipeline draws stereo by multiview
#extension GL_EXT_mesh_shader : require
#extension GL_EXT_shader_atomic_int64 : require
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) perprimitiveEXT flat in uvec2 inId;

#include "cluster_vis_atomic.glsl"
