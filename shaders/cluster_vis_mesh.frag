#version 460
// Visibility output of the mesh-shader backend (the id arrives per primitive).
#extension GL_EXT_multiview : require
#define MIRAGE_VIEW_INDEX gl_ViewIndex // 0 unless the pipeline draws stereo by multiview
#extension GL_EXT_mesh_shader : require
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) perprimitiveEXT flat in uvec2 inId;

#include "cluster_vis_frag.glsl"
