#pragma once
// Private sampling helpers: randomized Halton sequences and the maps from unit numbers to cell
// surface points and sphere directions.
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/visibility/view_cell.h"

namespace mirage::vis::detail {

inline constexpr uint32_t kHaltonPrimes[] = {2, 3, 5, 7, 11, 13, 17, 19};

// Van der Corput radical inverse. The base is a template argument so the divisions compile to
// multiplications: with a runtime base they cost more than tracing the ray they place.
inline uint64_t reverseBits(uint64_t x) {
  x = ((x >> 1) & 0x5555555555555555ull) | ((x & 0x5555555555555555ull) << 1);
  x = ((x >> 2) & 0x3333333333333333ull) | ((x & 0x3333333333333333ull) << 2);
  x = ((x >> 4) & 0x0f0f0f0f0f0f0f0full) | ((x & 0x0f0f0f0f0f0f0f0full) << 4);
  return __builtin_bswap64(x);
}

template <uint32_t Base> inline float radicalInverse(uint64_t index) {
  if constexpr (Base == 2) return float(double(reverseBits(index)) * 0x1p-64);
  if (index <= 0xffffffffu) {
    // Digits reversed into an integer, one division at the end: 32-bit division by a constant is a
    // multiply, and Base^21 (the most digits a 32-bit index has in base 3) still fits 64 bits.
    uint32_t i = uint32_t(index);
    uint64_t reversed = 0, scale = 1;
    while (i > 0) {
      reversed = reversed * Base + i % Base;
      i /= Base;
      scale *= Base;
    }
    return float(double(reversed) / double(scale));
  }
  double inv = 1.0 / Base, f = inv, r = 0.0;
  while (index > 0) {
    r += double(index % Base) * f;
    index /= Base;
    f *= inv;
  }
  return float(r);
}

inline float radicalInverse(uint64_t index, uint32_t base) {
  switch (base) {
  case 2:
    return radicalInverse<2>(index);
  case 3:
    return radicalInverse<3>(index);
  case 5:
    return radicalInverse<5>(index);
  case 7:
    return radicalInverse<7>(index);
  case 11:
    return radicalInverse<11>(index);
  case 13:
    return radicalInverse<13>(index);
  case 17:
    return radicalInverse<17>(index);
  default:
    return radicalInverse<19>(index);
  }
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
  // The current Cranley-Patterson offsets (for generators elsewhere, e.g. a GPU ray source).
  const std::array<float, Dims>& offsets() const { return offset_; }
  std::array<float, Dims> operator()(uint64_t index) const {
    std::array<float, Dims> out;
    [&]<size_t... D>(std::index_sequence<D...>) {
      ((out[D] = wrap(radicalInverse<kHaltonPrimes[D]>(index + 1) + offset_[D])), ...);
    }
    (std::make_index_sequence<Dims>{});
    return out;
  }

  // Consecutive points from `index` on, at amortized O(1) per point: each dimension's digits are
  // incremented like an odometer instead of being recomputed (the recomputation cost as much as
  // tracing the ray). Used by the loops that fill a block of consecutive samples.
  class Cursor {
  public:
    Cursor(const RandomizedHalton& h, uint64_t index) : offset_(h.offset_) {
      for (int d = 0; d < Dims; ++d) {
        uint64_t i = index + 1;
        for (digits_[d].fill(0); i > 0; i /= kHaltonPrimes[d])
          digits_[d][size_t(count_[d]++)] = uint8_t(i % kHaltonPrimes[d]);
        value_[d] = radicalInverse(index + 1, kHaltonPrimes[d]);
      }
    }
    std::array<float, Dims> operator()() const {
      std::array<float, Dims> out;
      for (int d = 0; d < Dims; ++d) out[size_t(d)] = wrap(float(value_[d]) + offset_[size_t(d)]);
      return out;
    }
    void next() {
      for (int d = 0; d < Dims; ++d) {
        const uint32_t base = kHaltonPrimes[d];
        const double inv = 1.0 / double(base);
        double step = inv;
        for (size_t k = 0; k < digits_[d].size(); ++k, step *= inv) {
          if (digits_[d][k] + 1u < base) {
            ++digits_[d][k];
            value_[d] += step;
            break;
          }
          value_[d] -= double(base - 1) * step; // this digit wraps to 0 and carries
          digits_[d][k] = 0;
        }
      }
    }

  private:
    std::array<float, Dims> offset_;
    std::array<std::array<uint8_t, 64>, Dims> digits_{};
    std::array<int, Dims> count_{};
    std::array<double, Dims> value_{};
  };
  Cursor cursor(uint64_t index) const { return Cursor(*this, index); }

private:
  static float wrap(float v) { return v >= 1.0f ? v - 1.0f : v; }
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
