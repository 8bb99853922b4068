#pragma once
// Private sampling helpers: randomized Halton sequences and the maps from unit numbers to cell
// surface points and sphere directions.
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/visibility/view_cell.h"

namespace mirage::vis::detail {

inline constexpr uint32_t kHaltonPrimes[] = {2, 3, 5, 7, 11, 13, 17, 19};

inline float radicalInverse(uint64_t index, uint32_t base) {
  double inv = 1.0 / base, f = inv, r = 0.0;
  while (index > 0) {
    r += double(index % base) * f;
    index /= base;
    f *= inv;
  }
  return float(r);
}

// Halton points with a Cranley-Patterson rotation: every iteration draws a fresh random offset, so
// successive iterations explore new samples instead of repeating the same low-discrepancy set.
template <int Dims> class RandomizedHalton {
public:
  explicit RandomizedHalton(uint64_t seed) : rng_(seed) { reshuffle(); }
  void reshuffle() {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float& o : offset_) o = u(rng_);
  }
  std::array<float, Dims> operator()(uint64_t index) const {
    std::array<float, Dims> out;
    for (int d = 0; d < Dims; ++d) {
      float v = radicalInverse(index + 1, kHaltonPrimes[d]) + offset_[size_t(d)];
      out[size_t(d)] = v >= 1.0f ? v - 1.0f : v;
    }
    return out;
  }

private:
  std::mt19937_64 rng_;
  std::array<float, Dims> offset_{};
};

// Uniform direction on the sphere.
inline glm::vec3 sphereDirection(float u, float v) {
  float z = 1.0f - 2.0f * u;
  float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  float phi = 2.0f * std::numbers::pi_v<float> * v;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Surface point of a cell: `select` picks a face with probability proportional to its area, (u, v)
// the point on it. Faces come from cellFaces(); `cdf` holds their cumulative area fractions.
struct SurfaceSampler {
  std::vector<CellFace> faces;
  std::vector<float> cdf;
  explicit SurfaceSampler(const ViewCell& cell) : faces(cellFaces(cell)) {
    float total = 0.0f;
    for (const CellFace& f : faces) total += f.area;
    float acc = 0.0f;
    for (const CellFace& f : faces) cdf.push_back(acc += f.area / total);
    cdf.back() = 1.0f;
  }
  glm::vec3 point(float select, float u, float v) const {
    size_t i = 0;
    while (i + 1 < cdf.size() && select >= cdf[i]) ++i;
    const CellFace& f = faces[i];
    return f.corner + f.edgeU * u + f.edgeV * v;
  }
};

} // namespace mirage::vis::detail
