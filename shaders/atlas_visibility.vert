#version 460
// Every atlas visibility pass: the depth prepass and the marking pass must produce the very same
// depths (the marking pass tests EQUAL), hence one vertex shader with an invariant position.
#include "atlas_visibility_common.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec2 inUv;
layout(location = 2) in vec4 inColor;

layout(location = 0) out vec2 outUv;
layout(location = 1) out vec4 outColor;
layout(location = 2) flat out uint outFirstTriangle;

invariant gl_Position;

void main() {
  GpuInstance inst = InstanceRef(push.instanceAddress).instances[gl_InstanceIndex];
  outUv = inUv;
  outColor = inColor;
  outFirstTriangle = UintRef(push.firstTriangleAddress).values[gl_InstanceIndex];
  gl_Position = push.viewProj * (inst.model * vec4(inPosition, 1.0));
}
