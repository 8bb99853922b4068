#version 460
// Visibility output of the indirect-draw backend.
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) flat in uvec2 inId;

#include "cluster_vis_frag.glsl"
