#version 460
// Hardware blend raster, indirect draws: fragments into the transparency lists (cluster_blend_frag.glsl).
#include "cluster_common.glsl"
#include "cluster_oit.glsl"

layout(location = 0) flat in uvec2 inId;

#include "cluster_blend_frag.glsl"
