#version 460
// cluster_vis_mesh.frag with the alpha MASK test (scenes with MASK materials).
#extension GL_EXT_multiview : require
#define MIRAGE_VIEW_INDEX gl_ViewIndex // 0 unless the pipeline draws stereo by multiview
#extension GL_EXT_mesh_shader : require
#define MIRAGE_VIS_MASK 1
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) perprimitiveEXT flat in uvec2 inId;

#include "cluster_vis_frag.glsl"
