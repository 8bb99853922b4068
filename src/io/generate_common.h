#pragma once
// Shared pieces of the procedural generators: a portable RNG and hash-based gradient noise. Both
// are written here (not <random>) so results are identical across standard libraries.
#include <cstdint>

#include <glm/glm.hpp>

#include "mirage/core/scene.h"

namespace mirage::io::detail {

struct SplitMix64 {
  uint64_t state;
  explicit SplitMix64(uint64_t seed) : state(seed) {}
  uint64_t next() {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  float uniform() { return float(next() >> 40) * (1.0f / 16777216.0f); } // [0, 1)
  float range(float lo, float hi) { return lo + (hi - lo) * uniform(); }
  uint32_t below(uint32_t n) { return n == 0 ? 0 : uint32_t(next() % n); }
};

// Perlin-style gradient noise in roughly [-1, 1]; zero at lattice points.
float gradientNoise3(glm::vec3 p, uint32_t seed);
// Fractal sum of octaves (lacunarity 2, gain 0.5), normalised to roughly [-1, 1].
float fbm3(glm::vec3 p, uint32_t octaves, uint32_t seed);
// Recompute Mesh::bounds from its positions.
void computeBounds(Mesh& mesh);

} // namespace mirage::io::detail
