// A particle's camera-facing quad (docs/particles.md, "Rendering"), written once for the renderers'
// billboards (particle_billboard.vert) and the streaming client's (atlas_client_particle.vert):
// vertex k (0..5, two triangles) lies in the view plane at the particle's view-space centre, edge
// `size` world units, turned by `rotation` about the view axis, so the quad faces any camera. A
// particle narrower than MIRAGE_PARTICLE_MIN_PIXELS is drawn that wide (particleGrow); the caller
// divides its alpha by grow^2 so its coverage stays. shaderio/particles.h included.

const vec2 kParticleCorners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));

struct ParticleCorner {
  vec4 clip;  // gl_Position
  vec2 uv;    // within the sheet tile, (0, 0) at its top left (view +Y up = the tile's top row)
  float grow; // the size factor of sub-pixel particles (1 otherwise)
};

ParticleCorner particleQuadCorner(mat4 view, mat4 proj, float viewportHeight, vec3 position, float size, float rotation,
                                  uint k) {
  vec2 c = kParticleCorners[k];
  vec4 centre = view * vec4(position, 1.0);
  float grow = particleGrow(particleEdgePixels(proj[1][1], viewportHeight, size, centre.z));
  float s = sin(rotation), co = cos(rotation);
  vec2 offset = vec2(co * c.x - s * c.y, s * c.x + co * c.y) * (0.5 * size * grow);
  ParticleCorner r;
  r.clip = proj * vec4(centre.xy + offset, centre.zw);
  r.uv = vec2(0.5 + 0.5 * c.x, 0.5 - 0.5 * c.y);
  r.grow = grow;
  return r;
}
