// Mixed scenes (docs/render.md, "Mixed scenes"): the cluster resolve shades pixels whose id carries
// MIRAGE_SURFEL_ID_TAG from the surfel renderer's arrays (ClusterSurfelLink), as
// surfel_render_resolve.comp does. Included after shading.glsl.
#include "mirage/shaderio/surfel_link.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LinkRef { ClusterSurfelLink link; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LinkStateRef { SurfelInstanceState states[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LinkInstanceRef { SurfelRenderInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LinkCloudRef { SurfelRenderCloud clouds[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer LinkUvec2Ref { uvec2 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LinkMaterialRef { GpuMaterial materials[]; };

vec3 linkQuantized(uvec2 p) {
  const uint mask = (1u << MIRAGE_SURFEL_POSITION_BITS) - 1u;
  return vec3(float(p.x & mask), float((p.x >> 21) | ((p.y & 0x3ffu) << 11)), float(p.y >> 10));
}

vec3 linkNormal(uint packed) {
  vec2 p = max(vec2(float(int(packed << 16) >> 16), float(int(packed) >> 16)) / 32767.0, vec2(-1.0));
  vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
  float t = max(-n.z, 0.0);
  n.x += n.x >= 0.0 ? -t : t;
  n.y += n.y >= 0.0 ? -t : t;
  return normalize(n);
}

// Shaded colour of surfel visibility id `id` (tag removed, >= 1). The caller passes a valid id on
// every lane (lavapipe runs the loads of inactive lanes too).
vec3 shadeLinkedSurfel(ClusterSurfelLink l, uint id, ClusterFrame f) {
  LinkStateRef states = LinkStateRef(l.stateAddress);
  uint lo = 0, hi = l.instanceCount; // the last instance whose first id is <= id
  while (hi - lo > 1u) {
    uint mid = (lo + hi) >> 1;
    if (states.states[mid].firstId <= id) lo = mid;
    else hi = mid;
  }
  SurfelInstanceState s = states.states[lo];
  SurfelRenderInstance inst = LinkInstanceRef(l.instanceAddress).instances[lo];
  SurfelRenderCloud cloud = LinkCloudRef(l.cloudAddress).clouds[inst.cloud];
  uint at = cloud.firstSurfel + min(id - s.firstId, max(cloud.count, 1u) - 1u);
  vec3 q = linkQuantized(LinkUvec2Ref(l.positionAddress).v[at]);
  uvec2 attr = LinkUvec2Ref(l.attributeAddress).v[at];
  vec3 pos = (inst.model * vec4(cloud.boxMin.xyz + q * cloud.boxStep.xyz, 1.0)).xyz;
  vec3 normal = mat3(inst.normalMatrix) * linkNormal(attr.x);
  GpuMaterial m = LinkMaterialRef(l.materialAddress).materials[cloud.material];
  SurfaceDerivatives d;
  d.dpdx = d.dpdy = vec3(0.0);
  d.duvdx = d.duvdy = vec2(0.0);
  m.baseColorTexture = -1; // the colour already holds the base colour (capture)
  vec4 base = unpackUnorm4x8(attr.y);
  return shadeSurface(m, base, pos, normal, vec4(0.0), true, vec2(0.0), d, f.eye.xyz, f.lightDir, f.skyAmbient.rgb,
                      f.groundAmbient.rgb);
}
