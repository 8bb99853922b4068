#version 460
// Particle billboards (docs/particles.md, "Rendering"): instance = one RenderParticle record (of the
// pushed batch, or named by a list of global records: the sorted keys, the splat's large
// particles), vertex = one of the quad's two triangles' corners (gl_VertexIndex 0..5, no vertex
// buffer), placed by particle_quad.glsl: camera-facing for any camera, sub-pixel particles grown
// with their alpha scaled by the area ratio.
#include "particle_billboard.glsl"
#include "particle_quad.glsl"

layout(location = 0) out vec2 outUv;
layout(location = 1) flat out vec4 outColor;
layout(location = 2) flat out uint outFrame;
layout(location = 3) flat out uvec4 outSheet;

void main() {
  RenderParticle p;
  if (push.mode == MIRAGE_PARTICLE_DRAW_RECORDS) {
    p = ParticleRecordRef(push.recordAddress).records[gl_InstanceIndex];
    outSheet = uvec4(push.sheet, push.tilesX, push.tilesY, push.flags);
  } else {
    uint g = push.mode == MIRAGE_PARTICLE_DRAW_KEYS ? uint(ParticleKeyRef(push.recordAddress).keys[gl_InstanceIndex])
                                                    : ParticleIndexRef(push.recordAddress).indices[gl_InstanceIndex];
    ParticleSlot slot = particleSlot(push.batchAddress, push.batchCount, g);
    p = particleRecord(slot);
    outSheet = uvec4(slot.info.sheet, slot.info.tilesX, slot.info.tilesY, slot.info.flags);
  }
  ParticleViewRef f = ParticleViewRef(push.frameAddress);
  ParticleCorner q = particleQuadCorner(f.camera.view, f.camera.proj, f.camera.viewport.y, p.position, p.size,
                                        p.rotation, uint(gl_VertexIndex));
  gl_Position = q.clip;
  outUv = q.uv;
  outColor = unpackUnorm4x8(p.color); // r in the low byte, as particlePackColor
  outColor.a /= q.grow * q.grow;      // the same coverage over the grown area
  outFrame = p.frame;
}
