#version 460
// Particle billboards (docs/particles.md, "Rendering"): instance = one RenderParticle record (of the
// pushed batch, or named by a list of global records: the sorted keys, the splat's large
// particles), vertex = one of the quad's two triangles' corners (gl_VertexIndex 0..5, no vertex
// buffer). The quad lies in the view plane at the particle's view-space centre, edge `size` world
// units, turned by `rotation` about the view axis: camera-facing for any camera. A particle smaller
// than kMinPixels on screen is drawn kMinPixels wide with its alpha scaled by the area ratio, so
// sub-pixel sparks and drops keep their average coverage instead of vanishing between pixel centres.
#include "particle_billboard.glsl"

layout(location = 0) out vec2 outUv;
layout(location = 1) flat out vec4 outColor;
layout(location = 2) flat out uint outFrame;
layout(location = 3) flat out uvec4 outSheet;

const float kMinPixels = 1.5;
const vec2 kCorners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

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
  vec2 c = kCorners[gl_VertexIndex];
  vec4 centre = f.camera.view * vec4(p.position, 1.0);
  float pixels = particlePixels(f, p.size, centre.z);
  float grow = pixels > 0.0 && pixels < kMinPixels ? kMinPixels / pixels : 1.0;
  float s = sin(p.rotation), k = cos(p.rotation);
  vec2 offset = vec2(k * c.x - s * c.y, s * c.x + k * c.y) * (0.5 * p.size * grow);
  gl_Position = f.camera.proj * vec4(centre.xy + offset, centre.zw);
  outUv = vec2(0.5 + 0.5 * c.x, 0.5 - 0.5 * c.y); // view +Y up = the tile's top row
  outColor = unpackUnorm4x8(p.color); // r in the low byte, as particlePackColor
  outColor.a /= grow * grow;          // the same coverage over the grown area
  outFrame = p.frame;
}
