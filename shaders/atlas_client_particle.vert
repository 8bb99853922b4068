#version 460
// The thin client's streamed particles (docs/stream.md, "Particles"): instance = one
// GpuClientParticle, vertex = a corner of its camera-facing quad (particle_quad.glsl, as the
// renderers' billboards), its uv the point of the look's sheet tile.
#include "atlas_client_common.glsl"
#include "mirage/shaderio/particles.h"
#include "particle_quad.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleRef {
  GpuClientParticle particles[];
};

layout(location = 0) out vec2 outUv;
layout(location = 1) flat out vec4 outColor;
layout(location = 2) flat out uvec2 outBlock; // GpuClientParticle block, blockLog2

void main() {
  GpuClientParticle p = ParticleRef(push.patchAddress).particles[gl_InstanceIndex];
  ViewRef f = ViewRef(push.frameAddress);
  ParticleCorner q = particleQuadCorner(f.view.view, f.view.proj, f.view.viewport.y, p.position, p.size, p.rotation,
                                        uint(gl_VertexIndex));
  gl_Position = q.clip;
  outUv = q.uv;
  outColor = unpackUnorm4x8(p.color);
  outColor.a /= q.grow * q.grow; // the same coverage over the grown area
  outBlock = uvec2(p.block, p.blockLog2);
}
