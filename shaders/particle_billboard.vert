#version 460
// Particle billboards (docs/particles.md, "Rendering"): instance = one RenderParticle record,
// vertex = one of the quad's two triangles' corners (gl_VertexIndex 0..5, no vertex buffer). The
// quad lies in the view plane at the particle's view-space centre, edge `size` world units,
// turned by `rotation` about the view axis: camera-facing for any camera. A particle smaller than
// kMinPixels on screen is drawn kMinPixels wide with its alpha scaled by the area ratio, so
// sub-pixel sparks and drops keep their average coverage instead of vanishing between pixel centres.
#include "particle_billboard.glsl"

layout(location = 0) out vec2 outUv;
layout(location = 1) flat out vec4 outColor;
layout(location = 2) flat out uint outFrame;

const float kMinPixels = 1.5;
const vec2 kCorners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

void main() {
  RenderParticle p = ParticleRecordRef(push.recordAddress).records[gl_InstanceIndex];
  ParticleFrameRef f = ParticleFrameRef(push.frameAddress);
  vec2 c = kCorners[gl_VertexIndex];
  vec4 centre = f.frame.camera.view * vec4(p.position, 1.0);
  // Projected edge in pixels (perspective: |proj[1][1]| / -z scales view units to NDC).
  float pixels = p.size * abs(f.frame.camera.proj[1][1]) * 0.5 * f.frame.camera.viewport.y / max(-centre.z, 1e-6);
  float grow = pixels > 0.0 && pixels < kMinPixels ? kMinPixels / pixels : 1.0;
  float s = sin(p.rotation), k = cos(p.rotation);
  vec2 offset = vec2(k * c.x - s * c.y, s * c.x + k * c.y) * (0.5 * p.size * grow);
  gl_Position = f.frame.camera.proj * vec4(centre.xy + offset, centre.zw);
  outUv = vec2(0.5 + 0.5 * c.x, 0.5 - 0.5 * c.y); // view +Y up = the tile's top row
  outColor = unpackUnorm4x8(p.color); // r in the low byte, as particlePackColor
  outColor.a /= grow * grow;          // the same coverage over the grown area
  outFrame = p.frame;
}
