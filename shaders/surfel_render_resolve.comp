#version 460
// Resolve, one thread per pixel: the visibility id names (instance, surfel); the surfel's position,
// normal and colour are fetched and shaded with the shared material model (shading.glsl), as the
// mesh resolve does, with the cloud's material for metallic / roughness (the colour already holds
// the base colour factor, baked in by the capture).
#extension GL_EXT_nonuniform_qualifier : require
#include "surfel_render_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];
layout(set = 0, binding = 1) uniform usampler2D visImage;

#include "shading.glsl"

layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D outImage;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  SurfelRenderFrame f = SrFrameRef(push.frameAddress).frame;
  // Stereo: one dispatch over both eyes side by side (rows of 2 * viewport.x, compute splat only);
  // the right half shades from the right eye.
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  int row = int(f.camera.viewport.x) * int(max(f.eyes, 1u));
  if (px.x >= row || px.y >= int(f.camera.viewport.y)) return;
  vec3 eye = f.camera.eye.xyz + (px.x >= int(f.camera.viewport.x) ? f.stereoEye.xyz : vec3(0.0));
  uint id = (f.flags & MIRAGE_SURFEL_SOURCE_BUFFER) != 0
                ? uint(SrVisRef(push.visBufferAddress).pixels[px.y * row + px.x] & 0xffffffffUL)
                : texelFetch(visImage, px, 0).x;
  if (id == 0u) {
    imageStore(outImage, px, f.background);
    return;
  }
  uint slot = findInstance(id);
  SurfelInstanceState s = SrStateRef(push.stateAddress).states[slot];
  SurfelRenderInstance inst = SrInstanceRef(push.instanceAddress).instances[slot];
  SurfelRenderCloud cloud = SrCloudRef(push.cloudAddress).clouds[inst.cloud];
  uint at = cloud.firstSurfel + (id - s.firstId);
  vec3 q = surfelQuantized(SrUvec2Ref(push.positionAddress).v[at]);
  uvec2 attr = SrUvec2Ref(push.attributeAddress).v[at];
  vec3 pos = (inst.model * vec4(cloud.boxMin.xyz + q * cloud.boxStep.xyz, 1.0)).xyz;
  vec3 normal = mat3(inst.normalMatrix) * surfelNormal(attr.x);
  GpuMaterial m = SrMaterialRef(push.materialAddress).materials[cloud.material];
  SurfaceDerivatives d;
  d.dpdx = d.dpdy = vec3(0.0);
  d.duvdx = d.duvdy = vec2(0.0);
  vec4 base = unpackUnorm4x8(attr.y); // linear RGBA8
  // The capture turned every normal towards the view that saw it: surfels are front-facing.
  vec3 rgb = shadeSurfaceLights(m, base, pos, normal, vec4(0.0), true, vec2(0.0), d, eye, f.lightDir, f.skyAmbient.rgb,
                                f.groundAmbient.rgb, f.lightAddress, f.lightCount);
  imageStore(outImage, px, vec4(rgb, 1.0));
}
