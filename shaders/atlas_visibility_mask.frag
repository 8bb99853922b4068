#version 460
// Depth prepass of alpha-MASK geometry: texels below the cutoff write no depth (forward.frag's test).
#include "atlas_visibility_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];
#include "shading.glsl"

layout(location = 0) in vec2 inUv;
layout(location = 1) in vec4 inColor;

void main() {
  GpuMaterial m = MaterialRef(push.materialAddress).materials[push.materialIndex];
  SurfaceDerivatives d;
  d.dpdx = vec3(0.0); // baseColor reads only the uv derivatives
  d.dpdy = vec3(0.0);
  d.duvdx = dFdx(inUv);
  d.duvdy = dFdy(inUv);
  if (baseColor(m, inUv, inColor, d).a < m.alphaCutoff) discard;
}
