#version 460
#include "forward_common.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) in vec4 inTangent;
layout(location = 4) in vec4 inColor;

layout(location = 0) out vec3 outWorldPos;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec2 outUv;
layout(location = 3) out vec4 outTangent;
layout(location = 4) out vec4 outColor;

void main() {
  GpuInstance inst = InstanceRef(push.instanceAddress).instances[gl_InstanceIndex];
  vec4 world = inst.model * vec4(inPosition, 1.0);
  outWorldPos = world.xyz;
  outNormal = mat3(inst.normalMatrix) * inNormal;
  outTangent = vec4(mat3(inst.model) * inTangent.xyz, inTangent.w);
  outUv = inUv;
  outColor = inColor;
  gl_Position = FrameRef(push.frameAddress).frame.camera.viewProj * world;
}
