#ifndef MIRAGE_SURFEL_DECODE_GLSL
#define MIRAGE_SURFEL_DECODE_GLSL
// Decoding of the packed 16-byte Surfel (include/mirage/shaderio/surfels.h), for every shader that
// reads surfels: the surfel renderer's passes and the cluster resolve of mixed scenes.

// Quantized position (Surfel::posLo, posHi) -> the three 21-bit integer coordinates as floats.
vec3 surfelQuantized(uvec2 p) {
  const uint mask = (1u << MIRAGE_SURFEL_POSITION_BITS) - 1u;
  return vec3(float(p.x & mask), float((p.x >> 21) | ((p.y & 0x3ffu) << 11)), float(p.y >> 10));
}

// Octahedral unit normal, two snorm16 (mirage/core/octahedral.h).
vec3 surfelNormal(uint packed) {
  vec2 p = max(vec2(float(int(packed << 16) >> 16), float(int(packed) >> 16)) / 32767.0, vec2(-1.0));
  vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
  float t = max(-n.z, 0.0);
  n.x += n.x >= 0.0 ? -t : t;
  n.y += n.y >= 0.0 ? -t : t;
  return normalize(n);
}

#endif
