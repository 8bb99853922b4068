#include "mirage/surfels/surfel.h"

#include <algorithm>
#include <cmath>

#include "kdtree.h"

namespace mirage::surfels {

namespace {

constexpr uint32_t kAxisSteps = (1u << MIRAGE_SURFEL_POSITION_BITS) - 1u;

uint32_t quantize(float v, float lo, float hi) {
  float t = hi > lo ? (v - lo) / (hi - lo) : 0.0f;
  return uint32_t(std::lround(std::clamp(t, 0.0f, 1.0f) * float(kAxisSteps)));
}

float dequantize(uint32_t q, float lo, float hi) { return lo + (hi - lo) * (float(q) / float(kAxisSteps)); }

} // namespace

uint32_t GBufferTexels::compactIndex(uint32_t globalId) const {
  auto it = std::lower_bound(ids.begin(), ids.end(), globalId);
  return it != ids.end() && *it == globalId ? uint32_t(it - ids.begin()) : UINT32_MAX;
}

Surfel packSurfel(const Bounds& box, glm::vec3 position, glm::vec3 normal, uint32_t color) {
  uint32_t x = quantize(position.x, box.min.x, box.max.x);
  uint32_t y = quantize(position.y, box.min.y, box.max.y);
  uint32_t z = quantize(position.z, box.min.z, box.max.z);
  Surfel s;
  s.posLo = x | (y & 0x7ffu) << 21;
  s.posHi = (y >> 11) | z << 10;
  s.normal = encodeOctahedral(normal);
  s.color = color;
  return s;
}

glm::vec3 surfelPosition(const Bounds& box, const Surfel& s) {
  uint32_t x = s.posLo & kAxisSteps;
  uint32_t y = (s.posLo >> 21) | (s.posHi & 0x3ffu) << 11;
  uint32_t z = s.posHi >> 10;
  return {dequantize(x, box.min.x, box.max.x), dequantize(y, box.min.y, box.max.y),
          dequantize(z, box.min.z, box.max.z)};
}

glm::vec3 surfelNormal(const Surfel& s) { return decodeOctahedral(s.normal); }

SurfelCloud buildSurfelCloud(const GBufferTexels& texels, const SampleOrder& order) {
  SurfelCloud cloud;
  for (uint32_t t : order.texels) cloud.box.add(texels.positions[t]);
  cloud.surfels.reserve(order.texels.size());
  for (uint32_t t : order.texels)
    cloud.surfels.push_back(packSurfel(cloud.box, texels.positions[t], texels.normals[t], texels.colors[t]));
  cloud.radii = order.radii;

  // N_ref spacing: what the renderer's prefix-length formula k = N_ref · d² / r² needs.
  cloud.referenceCount = uint32_t(std::min<size_t>(1000, order.texels.size()));
  if (cloud.referenceCount >= 2) {
    std::vector<glm::vec3> points;
    for (uint32_t i = 0; i < cloud.referenceCount; ++i) points.push_back(texels.positions[order.texels[i]]);
    KdTree tree(points);
    std::vector<float> nn(points.size());
    for (uint32_t i = 0; i < points.size(); ++i) nn[i] = std::sqrt(tree.nearestSquared(points[i], i));
    double sum = 0.0;
    for (float d : nn) sum += d;
    cloud.referenceMeanSpacing = float(sum / double(nn.size()));
    std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
    cloud.referenceMedianSpacing = nn[nn.size() / 2];
  }
  return cloud;
}

} // namespace mirage::surfels
