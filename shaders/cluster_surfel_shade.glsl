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

#include "surfel_decode.glsl"

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
  vec3 q = surfelQuantized(LinkUvec2Ref(l.positionAddress).v[at]);
  uvec2 attr = LinkUvec2Ref(l.attributeAddress).v[at];
  vec3 pos = (inst.model * vec4(cloud.boxMin.xyz + q * cloud.boxStep.xyz, 1.0)).xyz;
  vec3 normal = mat3(inst.normalMatrix) * surfelNormal(attr.x);
  GpuMaterial m = LinkMaterialRef(l.materialAddress).materials[cloud.material];
  SurfaceDerivatives d;
  d.dpdx = d.dpdy = vec3(0.0);
  d.duvdx = d.duvdy = vec2(0.0);
  m.baseColorTexture = -1; // the colour already holds the base colour (capture)
  vec4 base = unpackUnorm4x8(attr.y);
  return shadeSurfaceLights(m, base, pos, normal, vec4(0.0), true, vec2(0.0), d, f.camera.eye.xyz, f.lightDir,
                            f.skyAmbient.rgb, f.groundAmbient.rgb, f.lightAddress, f.lightCount);
}
