#include "mirage/core/octahedral.h"

#include <algorithm>
#include <cmath>

namespace mirage {

namespace {
int16_t toSnorm16(float v) { return int16_t(std::lround(std::clamp(v, -1.0f, 1.0f) * 32767.0f)); }
} // namespace

uint32_t encodeOctahedral(glm::vec3 n) {
  n /= std::abs(n.x) + std::abs(n.y) + std::abs(n.z) + 1e-30f;
  glm::vec2 p(n.x, n.y);
  if (n.z < 0.0f)
    p = glm::vec2((1.0f - std::abs(n.y)) * (n.x >= 0.0f ? 1.0f : -1.0f),
                  (1.0f - std::abs(n.x)) * (n.y >= 0.0f ? 1.0f : -1.0f));
  return uint32_t(uint16_t(toSnorm16(p.x))) | uint32_t(uint16_t(toSnorm16(p.y))) << 16;
}

glm::vec3 decodeOctahedral(uint32_t packed) {
  glm::vec2 p(std::max(float(int16_t(packed & 0xffffu)) / 32767.0f, -1.0f),
              std::max(float(int16_t(packed >> 16)) / 32767.0f, -1.0f));
  glm::vec3 n(p.x, p.y, 1.0f - std::abs(p.x) - std::abs(p.y));
  float t = std::max(-n.z, 0.0f);
  n.x += n.x >= 0.0f ? -t : t;
  n.y += n.y >= 0.0f ? -t : t;
  return glm::normalize(n);
}

} // namespace mirage
