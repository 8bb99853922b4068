// GVS++ exploration rays made on the host (explore_rays.h).
#include "explore_rays.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mirage/shaderio/gvs_explore.h"
#include "sampling.h"

namespace mirage::vis::detail {

namespace {

constexpr Ray kSkipped{.tfar = -1.0f};

// The ray from `origin` towards `target`, or kSkipped where no ray is made.
Ray towards(glm::vec3 origin, glm::vec3 target) {
  glm::vec3 d = target - origin;
  if (glm::dot(d, d) < 1e-30f) return kSkipped;
  Ray ray{.origin = origin, .dir = glm::normalize(d)};
  return validRay(ray) ? ray : kSkipped; // never hand a backend a NaN or far-out ray
}

// One item's border polygon: the triangle, its edges' outward normals and Δ_ABS.
struct Border {
  bool degenerate = true;
  std::array<glm::vec3, 3> v;
  glm::vec3 en[3];
  float delta = 0.0f;
  Border(const std::array<glm::vec3, 3>& tri, const ExploreRaySource& s) : v(tri) {
    glm::vec3 n = glm::cross(v[1] - v[0], v[2] - v[0]);
    if (glm::dot(n, n) < 1e-30f) return; // degenerate: no border to follow
    degenerate = false;
    en[0] = shaderio::absEdgeNormal(v[0], v[1], v[2], n);
    en[1] = shaderio::absEdgeNormal(v[1], v[2], v[0], n);
    en[2] = shaderio::absEdgeNormal(v[2], v[0], v[1], n);
    delta = shaderio::absDelta(v[0], v[1], v[2], s.absDeltaTriangle, s.absDeltaAbsolute);
  }
  glm::vec3 point(uint32_t k, uint32_t edgeSamples) const {
    return shaderio::absPoint(v[0], v[1], v[2], en[0], en[1], en[2], delta, k, edgeSamples);
  }
};

float edgeLength(const ExploreRaySource& s) {
  float total = 0.0f;
  for (const auto& e : s.edges) total += glm::length(e[1] - e[0]);
  return total;
}

// Point `t` (0..1) along the cell's edges, by length.
glm::vec3 edgePoint(const ExploreRaySource& s, float total, float t) {
  float at = t * total;
  for (const auto& e : s.edges) {
    float len = glm::length(e[1] - e[0]);
    if (at <= len) return glm::mix(e[0], e[1], len > 0.0f ? at / len : 0.0f);
    at -= len;
  }
  return s.edges.back()[1];
}

float wrapUnit(float v) { return v >= 1.0f ? v - 1.0f : v; }

// RS origin j of the seed with sequence index `seed`: evenly along the cell's edges (shifted per
// seed so seeds differ), then randomized Halton points on its surface (RandomizedHalton<3>).
glm::vec3 reverseOrigin(const ExploreRaySource& s, float total, uint64_t seed, uint32_t j) {
  if (j < s.rsEdgeSamples) return edgePoint(s, total, (float(j) + radicalInverse(seed, 2)) / float(s.rsEdgeSamples));
  const uint64_t h = seed * s.rsAreaSamples + (j - s.rsEdgeSamples) + 1;
  const float select = wrapUnit(radicalInverse<2>(h) + s.rsOffset[0]);
  const float u = wrapUnit(radicalInverse<3>(h) + s.rsOffset[1]);
  const float v = wrapUnit(radicalInverse<5>(h) + s.rsOffset[2]);
  size_t f = 0;
  while (f + 1 < s.cdf.size() && select >= s.cdf[f]) ++f;
  return s.faces[f].corner + s.faces[f].edgeU * u + s.faces[f].edgeV * v;
}

Ray reverseRay(const ExploreRaySource::ReverseItem& item, const std::array<glm::vec3, 3>& occluder, glm::vec3 o) {
  glm::vec3 d = item.target - o;
  if (glm::dot(d, d) < 1e-30f) return kSkipped;
  // Inside the occluder's shadow on the cell: the occluder blocks this origin too.
  if (item.occluder != kNoHit &&
      shaderio::segmentHitsTriangle(item.target, o - item.target, occluder[0], occluder[1], occluder[2]))
    return kSkipped;
  return towards(o, item.target);
}

} // namespace

void makeExploreRays(const Scene& scene, std::span<const uint64_t> offsets, const ExploreRaySource& s,
                     std::span<Ray> rays, std::span<glm::vec3> targets) {
  const bool border = s.kind == ExploreRaySource::Kind::Border;
  const size_t items = border ? s.border.size() : s.reverse.size();
  const size_t per = s.raysPerItem;
  const float total = border ? 0.0f : edgeLength(s);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, items, 64), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t q = r.begin(); q < r.end(); ++q) {
      Ray* out = rays.data() + q * per;
      if (border) {
        const auto& item = s.border[q];
        Border b(worldTriangle(scene, offsets, item.triangle), s);
        for (uint32_t k = 0; k < per; ++k) {
          if (b.degenerate) {
            out[k] = kSkipped;
            continue;
          }
          glm::vec3 p = b.point(k, s.absEdgeSamples);
          out[k] = towards(item.origin, p);
          if (!targets.empty()) targets[q * per + k] = p;
        }
      } else {
        const auto& item = s.reverse[q];
        std::array<glm::vec3, 3> occ{};
        if (item.occluder != kNoHit) occ = worldTriangle(scene, offsets, item.occluder);
        for (uint32_t j = 0; j < per; ++j) out[j] = reverseRay(item, occ, reverseOrigin(s, total, s.firstSeed + q, j));
      }
    }
  });
}

Ray exploreRay(const Scene& scene, std::span<const uint64_t> offsets, const ExploreRaySource& s, size_t slot) {
  const size_t q = slot / s.raysPerItem;
  const uint32_t k = uint32_t(slot % s.raysPerItem);
  // No skip tests: a slot the device traced keeps its origin even where the host's rounding would
  // have skipped it (a shadow test on its threshold).
  auto aimed = [](glm::vec3 origin, glm::vec3 target) {
    glm::vec3 d = target - origin;
    return Ray{.origin = origin, .dir = glm::dot(d, d) > 0.0f ? glm::normalize(d) : glm::vec3(0, 0, 1)};
  };
  if (s.kind == ExploreRaySource::Kind::Border) {
    const auto& item = s.border[q];
    Border b(worldTriangle(scene, offsets, item.triangle), s);
    return b.degenerate ? Ray{.origin = item.origin} : aimed(item.origin, b.point(k, s.absEdgeSamples));
  }
  const auto& item = s.reverse[q];
  return aimed(reverseOrigin(s, edgeLength(s), s.firstSeed + q, k), item.target);
}

} // namespace mirage::vis::detail
