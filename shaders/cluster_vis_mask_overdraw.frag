#version 460
// cluster_vis_mask.frag counting every covered sample for the overdraw debug view (docs/render.md,
// "Debug views"), created on first use: the store keeps the depth test after the shader, which
// the normal variants must not pay.
#define MIRAGE_VIS_MASK 1
#define MIRAGE_VIS_OVERDRAW 1
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) flat in uvec2 inId;

#include "cluster_vis_frag.glsl"
