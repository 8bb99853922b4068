#include "generate_common.h"

#include <cmath>

namespace mirage::io::detail {

namespace {

uint32_t mix32(uint32_t x) { // "lowbias32" integer finaliser: good avalanche, cheap
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

uint32_t hash3(int32_t x, int32_t y, int32_t z, uint32_t seed) {
  uint32_t h = mix32(seed ^ 0x9E3779B9U);
  h = mix32(h ^ uint32_t(x) * 0x85EBCA6BU);
  h = mix32(h ^ uint32_t(y) * 0xC2B2AE35U);
  return mix32(h ^ uint32_t(z) * 0x27D4EB2FU);
}

// Dot product with one of Perlin's 12 cube-edge gradients.
float grad(uint32_t h, float x, float y, float z) {
  switch (h % 12) {
  case 0:
    return x + y;
  case 1:
    return -x + y;
  case 2:
    return x - y;
  case 3:
    return -x - y;
  case 4:
    return x + z;
  case 5:
    return -x + z;
  case 6:
    return x - z;
  case 7:
    return -x - z;
  case 8:
    return y + z;
  case 9:
    return -y + z;
  case 10:
    return y - z;
  default:
    return -y - z;
  }
}

float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
float lerp(float a, float b, float t) { return a + (b - a) * t; }

} // namespace

float gradientNoise3(glm::vec3 p, uint32_t seed) {
  glm::vec3 f = glm::floor(p);
  int32_t x = int32_t(f.x), y = int32_t(f.y), z = int32_t(f.z);
  glm::vec3 d = p - f;
  float u = fade(d.x), v = fade(d.y), w = fade(d.z);
  auto g = [&](int dx, int dy, int dz) {
    return grad(hash3(x + dx, y + dy, z + dz, seed), d.x - float(dx), d.y - float(dy), d.z - float(dz));
  };
  float x00 = lerp(g(0, 0, 0), g(1, 0, 0), u), x10 = lerp(g(0, 1, 0), g(1, 1, 0), u);
  float x01 = lerp(g(0, 0, 1), g(1, 0, 1), u), x11 = lerp(g(0, 1, 1), g(1, 1, 1), u);
  return lerp(lerp(x00, x10, v), lerp(x01, x11, v), w);
}

float fbm3(glm::vec3 p, uint32_t octaves, uint32_t seed) {
  float sum = 0.0f, amplitude = 1.0f, norm = 0.0f;
  for (uint32_t o = 0; o < octaves; ++o) {
    // A per-octave offset keeps the octaves' lattice zeros from lining up at the origin.
    glm::vec3 offset(float(o) * 17.31f, float(o) * 9.77f, float(o) * 23.11f);
    sum += amplitude * gradientNoise3(p + offset, seed + o * 1013u);
    norm += amplitude;
    amplitude *= 0.5f;
    p *= 2.0f;
  }
  return norm > 0.0f ? sum / norm : 0.0f;
}

void computeBounds(Mesh& mesh) {
  mesh.bounds = Bounds{};
  for (const glm::vec3& p : mesh.positions) mesh.bounds.add(p);
}

} // namespace mirage::io::detail
