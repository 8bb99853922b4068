#version 460
// G-buffer capture: world position (w = 1 marks a texel that saw the surface), unit normal facing
// the viewer, base colour (vertex colour × factor × base colour texture).
// Depth peeling (layer > 0): only surfaces more than peelEpsilon behind the previous layer's
// surface at this texel. Back faces there are the inside of closed surfaces that other views see
// from the front, so they only carry the peeling depth (w = 0.25: not a sample, but layer + 1
// peels behind it).
#extension GL_EXT_multiview : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/surfels.h"

layout(push_constant, scalar) uniform Push { SurfelCapturePush push; };
layout(set = 0, binding = 0) uniform sampler2D baseColorTextures[];

layout(location = 0) in vec3 inWorldPos;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inColor;
layout(location = 3) in vec2 inUv;

layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;

void main() {
  float valid = 1.0;
  if (push.previousLayer != 0ul) {
    uint view = push.baseView + gl_ViewIndex;
    uvec2 texel = uvec2(gl_FragCoord.xy);
    uint index = (view * push.resolution + texel.y) * push.resolution + texel.x;
    vec4 previous = SurfelVec4Ref(push.previousLayer).v[index];
    vec3 towardsCamera = SurfelViewRef(push.viewAddress).v[view].direction.xyz;
    if (previous.w == 0.0 || dot(previous.xyz - inWorldPos, towardsCamera) <= push.peelEpsilon) discard;
    if (!gl_FrontFacing) valid = 0.25;
  }
  vec3 n = normalize(inNormal);
  if (!gl_FrontFacing) n = -n; // back faces of open or double-sided surfaces are sampled too
  outPosition = vec4(inWorldPos, valid);
  outNormal = vec4(n, 0.0);
  outColor = clamp(inColor * texture(baseColorTextures[push.baseColorTexture], inUv), 0.0, 1.0);
}
