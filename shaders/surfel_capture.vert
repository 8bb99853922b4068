#version 460
// G-buffer capture: one orthographic view per multiview view index (several passes when the device
// has fewer views than directions; baseView says which).
#extension GL_EXT_multiview : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/surfels.h"

layout(push_constant, scalar) uniform Push { SurfelCapturePush push; };

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inColor;
layout(location = 3) in vec2 inUv;

layout(location = 0) out vec3 outWorldPos;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec4 outColor;
layout(location = 3) out vec2 outUv;

void main() {
  SurfelInstance inst = SurfelInstanceRef(push.instanceAddress).v[gl_InstanceIndex];
  vec4 world = inst.model * vec4(inPosition, 1.0);
  outWorldPos = world.xyz;
  outNormal = mat3(inst.normalMatrix) * inNormal;
  outColor = inColor * push.baseColor;
  outUv = inUv;
  gl_Position = SurfelViewRef(push.viewAddress).v[push.baseView + gl_ViewIndex].viewProj * world;
}
