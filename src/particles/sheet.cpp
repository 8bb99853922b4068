// Procedural flipbook sheets: radial profiles shaped by value noise (hashed lattice, smooth
// interpolation, three octaves). Frame f of n gets the phase t = f / max(n - 1, 1).
#include "mirage/particles/sheet.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "mirage/shaderio/particles.h"

namespace mirage::particles {

namespace {

float lattice(int x, int y, uint32_t seed) {
  uint32_t h = shaderio::particleHash(uint32_t(x) * 73856093u ^ uint32_t(y) * 19349663u ^ seed);
  return float(h >> 8) / 16777216.0f;
}

float valueNoise(float x, float y, uint32_t seed) {
  int xi = int(std::floor(x)), yi = int(std::floor(y));
  float fx = x - float(xi), fy = y - float(yi);
  fx = fx * fx * (3.0f - 2.0f * fx);
  fy = fy * fy * (3.0f - 2.0f * fy);
  float a = lattice(xi, yi, seed), b = lattice(xi + 1, yi, seed);
  float c = lattice(xi, yi + 1, seed), d = lattice(xi + 1, yi + 1, seed);
  return (a + (b - a) * fx) + ((c + (d - c) * fx) - (a + (b - a) * fx)) * fy;
}

float fbm(float x, float y, uint32_t seed) {
  float sum = 0.0f, amplitude = 0.5f;
  for (int o = 0; o < 3; ++o, x *= 2.0f, y *= 2.0f, amplitude *= 0.5f)
    sum += amplitude * valueNoise(x, y, seed + uint32_t(o));
  return sum / 0.875f;
}

float smooth(float e0, float e1, float x) {
  float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// Alpha of a tile pixel at (u, v) in [-1, 1]^2 (v down) at phase t in [0, 1].
float sprite(int kind, float u, float v, float t, uint32_t seed) {
  float r = std::sqrt(u * u + v * v);
  switch (kind) {
  case 1: { // puff: grows from 0.6 to 1 of the tile, noise erodes it, it thins out
    float radius = 0.6f + 0.4f * t;
    float n = fbm(u * 2.5f + t * 1.5f, v * 2.5f - t, seed);
    return smooth(radius, radius * 0.3f, r) * (0.55f + 0.45f * n) * (1.0f - 0.6f * t);
  }
  case 2: { // spark: a core and a vertical streak that shortens
    float streak = smooth(0.15f, 0.0f, std::abs(u)) * smooth(0.9f * (1.0f - t) + 0.1f, 0.0f, std::abs(v));
    return std::min(1.0f, smooth(0.35f, 0.0f, r) + streak);
  }
  case 3: { // flame: a tongue (narrow at the top), flickering noise, shrinking
    float height = 1.0f - 0.5f * t;
    float width = 0.55f * std::clamp((v + 1.0f) / 2.0f, 0.0f, 1.0f) + 0.1f; // v down: wide at the bottom
    float n = fbm(u * 3.0f, v * 3.0f + t * 4.0f, seed);
    float body = smooth(width, width * 0.3f, std::abs(u) + 0.15f * (n - 0.5f)) * smooth(-height, -height + 0.4f, v) *
                 smooth(1.0f, 0.7f, v);
    return body * (0.7f + 0.3f * n);
  }
  case 4: // drop: a thin vertical streak, constant
    return smooth(0.12f, 0.0f, std::abs(u)) * smooth(1.0f, 0.2f, std::abs(v));
  default: // none: a soft disc
    return smooth(1.0f, 0.0f, r);
  }
}

} // namespace

Result<ImageRGBA8> generateSheet(std::string_view kind, uint32_t tilesX, uint32_t tilesY, uint32_t tileSize,
                                 uint32_t seed) {
  static constexpr std::string_view kKinds[] = {"none", "puff", "spark", "flame", "drop"};
  int k = -1;
  for (int i = 0; i < 5; ++i)
    if (kind == kKinds[i]) k = i;
  if (k < 0) return Error{fmt::format("texture sheet \"{}\": expected none, puff, spark, flame or drop", kind)};
  if (tilesX == 0 || tilesY == 0 || tileSize == 0 || uint64_t(tilesX) * tileSize > 4096 ||
      uint64_t(tilesY) * tileSize > 4096)
    return Error{
        fmt::format("texture sheet {}x{} tiles of {} pixels: outside 1..4096 pixels a side", tilesX, tilesY, tileSize)};
  ImageRGBA8 image{tilesX * tileSize, tilesY * tileSize, {}};
  image.pixels.resize(size_t(image.width) * image.height * 4);
  uint32_t frames = tilesX * tilesY;
  for (uint32_t y = 0; y < image.height; ++y)
    for (uint32_t x = 0; x < image.width; ++x) {
      uint32_t frame = (y / tileSize) * tilesX + x / tileSize;
      float t = float(frame) / float(std::max(frames - 1, 1u));
      float u = (float(x % tileSize) + 0.5f) / float(tileSize) * 2.0f - 1.0f;
      float v = (float(y % tileSize) + 0.5f) / float(tileSize) * 2.0f - 1.0f;
      float a = std::clamp(sprite(k, u, v, t, seed), 0.0f, 1.0f);
      auto byte = uint8_t(std::lround(a * 255.0f));
      uint8_t* p = image.at(x, y);
      p[0] = p[1] = p[2] = byte; // luminance = alpha (alpha_from_greyscale)
      p[3] = byte;
    }
  return image;
}

Result<ImageRGBA8> systemSheet(const SystemDef& system) {
  auto image = generateSheet(system.sheet.texture, system.sheet.tilesX, system.sheet.tilesY, kSheetTilePixels);
  if (!image) return Error{fmt::format("system \"{}\": {}", system.name, image.error().message)};
  return image;
}

} // namespace mirage::particles
