#include "mirage/core/color.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mirage {

uint8_t linearToSrgb8(float linear) {
  float v = std::isnan(linear) ? 0.0f : std::clamp(linear, 0.0f, 1.0f);
  float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return uint8_t(std::lround(s * 255.0f));
}

float srgb8ToLinear(uint8_t encoded) {
  // A table makes decoding exact-per-value and cheap for whole images.
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      double s = i / 255.0;
      t[i] = float(s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table[encoded];
}

} // namespace mirage
