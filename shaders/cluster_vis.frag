#version 460
// Visibility output of the indirect-draw backend.
#include "cluster_common.glsl"
#include "cluster_vis_alpha.glsl"

layout(location = 0) flat in uvec2 inId;
layout(location = 0) out uvec2 outVis;

void main() {
  if (!keepFacing(inId.x - 1, gl_FrontFacing) || !fragmentAlphaKeeps(inId.x - 1, inId.y, gl_FragCoord.xy)) discard;
  outVis = inId;
}
