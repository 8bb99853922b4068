#include "partition.h"

#include <algorithm>
#include <cmath>

#include <metis.h>

namespace mirage::lod::detail {

std::vector<uint32_t> partitionGraph(const std::vector<int32_t>& xadj, const std::vector<int32_t>& adjncy,
                                     const std::vector<int32_t>& weights, uint32_t parts) {
  idx_t n = idx_t(xadj.size() - 1);
  std::vector<uint32_t> result(size_t(n), 0);
  if (parts <= 1 || n <= 1) return result;
  std::vector<idx_t> part(size_t(n), 0);
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 42; // deterministic builds
  options[METIS_OPTION_NUMBERING] = 0;
  idx_t ncon = 1, nparts = idx_t(parts), objval = 0;
  // METIS takes non-const pointers but does not modify the graph.
  int rc = METIS_PartGraphRecursive(&n, &ncon, const_cast<idx_t*>(xadj.data()), const_cast<idx_t*>(adjncy.data()),
                                    nullptr, nullptr, const_cast<idx_t*>(weights.data()), &nparts, nullptr, nullptr,
                                    options, &objval, part.data());
  if (rc != METIS_OK) {
    for (idx_t i = 0; i < n; ++i) result[size_t(i)] = uint32_t(uint64_t(i) * parts / uint64_t(n));
    return result;
  }
  for (idx_t i = 0; i < n; ++i) result[size_t(i)] = uint32_t(part[size_t(i)]);
  return result;
}

LodBounds mergeSpheres(const LodBounds& a, const LodBounds& b) {
  glm::vec3 d = b.center - a.center;
  float dist = glm::length(d);
  if (dist + b.radius <= a.radius) return a;
  if (dist + a.radius <= b.radius) return b;
  LodBounds s;
  s.radius = (dist + a.radius + b.radius) * 0.5f;
  s.center = a.center + d * ((s.radius - a.radius) / dist);
  // Float rounding may leave the inputs a hair outside; grow by a relative epsilon.
  s.radius *= 1.0f + 1e-6f;
  s.error = std::max(a.error, b.error);
  return s;
}

LodBounds boundingSphere(const glm::vec3* points, size_t count) {
  LodBounds s;
  if (count == 0) return s;
  glm::vec3 lo = points[0], hi = points[0];
  for (size_t i = 1; i < count; ++i) lo = glm::min(lo, points[i]), hi = glm::max(hi, points[i]);
  s.center = (lo + hi) * 0.5f;
  float r2 = 0.0f;
  for (size_t i = 0; i < count; ++i) {
    glm::vec3 d = points[i] - s.center;
    r2 = std::max(r2, glm::dot(d, d));
  }
  s.radius = std::sqrt(r2) * (1.0f + 1e-6f);
  return s;
}

} // namespace mirage::lod::detail
