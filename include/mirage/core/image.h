#pragma once
// CPU images: 8-bit sRGB RGBA for PNG and golden tests, 32-bit float RGBA (linear) for metrics/EXR.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mirage {

struct ImageRGBA8 {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> pixels; // row-major, top row first, 4 bytes per pixel
  const uint8_t* at(uint32_t x, uint32_t y) const { return &pixels[(size_t(y) * width + x) * 4]; }
  uint8_t* at(uint32_t x, uint32_t y) { return &pixels[(size_t(y) * width + x) * 4]; }
};

struct ImageF32 {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> pixels; // row-major, top row first, 4 floats per pixel (RGBA, linear)
};

} // namespace mirage
