// The forward renderer's surface (forward.vert's outputs shaded with the material model of
// shading.glsl), shared by the opaque pass and every transparency pass: rgb, alpha = base-colour
// alpha for BLEND materials (1 otherwise). MASK pixels below the cutoff are discarded.
layout(set = 0, binding = 0) uniform sampler2D textures[];

layout(location = 0) in vec3 inWorldPos;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) in vec4 inTangent;
layout(location = 4) in vec4 inColor;

#include "shading.glsl"

vec4 shadeForwardSurface() {
  FrameData frame = FrameRef(push.frameAddress).frame;
  GpuMaterial m = MaterialRef(push.materialAddress).materials[push.materialIndex];
  SurfaceDerivatives d;
  d.dpdx = dFdx(inWorldPos);
  d.dpdy = dFdy(inWorldPos);
  d.duvdx = dFdx(inUv);
  d.duvdy = dFdy(inUv);

  vec4 base = baseColor(m, inUv, inColor, d);
  if (m.alphaMode == MIRAGE_ALPHA_MASK && base.a < m.alphaCutoff) discard;
  vec3 rgb = shadeSurfaceLights(m, base, inWorldPos, inNormal, inTangent, gl_FrontFacing, inUv, d,
                                frame.camera.eye.xyz, frame.lightDir, frame.skyAmbient.rgb, frame.groundAmbient.rgb,
                                frame.lightAddress, frame.lightCount);
  float alpha = m.alphaMode == MIRAGE_ALPHA_BLEND ? base.a : 1.0;
  return vec4(rgb, alpha);
}
