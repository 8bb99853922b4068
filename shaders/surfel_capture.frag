#version 460
// G-buffer capture: world position (w = 1 marks a texel that saw the surface), unit normal facing
// the viewer, base colour.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/surfels.h"

layout(location = 0) in vec3 inWorldPos;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inColor;

layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outColor;

void main() {
  vec3 n = normalize(inNormal);
  if (!gl_FrontFacing) n = -n; // back faces of open or double-sided surfaces are sampled too
  outPosition = vec4(inWorldPos, 1.0);
  outNormal = vec4(n, 0.0);
  outColor = clamp(inColor, 0.0, 1.0);
}
