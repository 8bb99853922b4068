#include "mirage/surfels/reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "kdtree.h"

namespace mirage::surfels {

uint32_t firstSampleTexel(const GBufferTexels& t) {
  uint32_t best = 0;
  float bestDistance = -1.0f;
  for (uint32_t i = 0; i < t.size(); ++i) {
    float d = glm::length(t.positions[i] - t.center);
    if (d >= bestDistance) bestDistance = d, best = i; // >=: ties go to the later (larger) id
  }
  return best;
}

SampleOrder farthestPointReference(const GBufferTexels& t, uint32_t count) {
  SampleOrder order;
  if (t.size() == 0 || count == 0) return order;
  KdTree tree(t.positions);
  std::vector<float> dist(t.size());
  uint32_t first = firstSampleTexel(t);
  glm::vec3 p0 = t.positions[first];
  tbb::parallel_for(size_t(0), t.size(), [&](size_t i) { dist[i] = glm::length(t.positions[i] - p0); });
  dist[first] = 0.0f;
  order.texels.push_back(first);
  order.radii.push_back(2.0f * t.sphereRadius);

  // Heap entries are upper bounds of the current distances (they only shrink): a popped entry that
  // is stale goes back with its current value, a fresh one is the true farthest texel.
  using Entry = std::pair<float, uint32_t>; // (distance, texel): max-heap, ties to the larger index
  std::vector<Entry> storage;
  storage.reserve(t.size());
  for (uint32_t i = 0; i < t.size(); ++i) storage.push_back({dist[i], i});
  std::priority_queue<Entry> heap(std::less<Entry>(), std::move(storage));
  while (order.texels.size() < count && !heap.empty()) {
    auto [d, i] = heap.top();
    heap.pop();
    if (d != dist[i]) {
      heap.push({dist[i], i});
      continue;
    }
    if (d <= 0.0f) break; // every texel is a sample
    order.texels.push_back(i);
    order.radii.push_back(d);
    dist[i] = 0.0f;
    // Only texels closer than the current maximum d can get closer to the new sample than before.
    tree.forEachWithin(t.positions[i], d, [&](uint32_t j, float d2) {
      float dj = std::sqrt(d2);
      if (dj < dist[j]) dist[j] = dj;
    });
  }
  return order;
}

PrefixQuality measurePrefix(const GBufferTexels& t, const SampleOrder& order, uint32_t count) {
  PrefixQuality q;
  count = std::min<uint32_t>(count, uint32_t(order.texels.size()));
  if (count < 2) return q;
  q.count = count;
  q.radius = order.radii[count - 1];
  std::vector<glm::vec3> points(count);
  for (uint32_t i = 0; i < count; ++i) points[i] = t.positions[order.texels[i]];
  KdTree tree(points);
  float minNn2 = tbb::parallel_reduce(
      tbb::blocked_range<uint32_t>(0, count, 1024), std::numeric_limits<float>::infinity(),
      [&](const tbb::blocked_range<uint32_t>& r, float best) {
        for (uint32_t i = r.begin(); i < r.end(); ++i) best = std::min(best, tree.nearestSquared(points[i], i));
        return best;
      },
      [](float a, float b) { return std::min(a, b); });
  q.rMin = 0.5 * std::sqrt(double(minNn2));
  q.rMax = std::sqrt(t.totalArea / (2.0 * std::sqrt(3.0) * double(count)));
  q.rho = q.rMax > 0.0 ? q.rMin / q.rMax : 0.0;
  // A relative epsilon: the radius was computed as the same float distance the coverage test sees.
  double covered2 = q.radius * q.radius * (1.0 + 1e-5);
  size_t covered = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, t.size(), 4096), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t n) {
        for (size_t i = r.begin(); i < r.end(); ++i) n += double(tree.nearestSquared(t.positions[i])) <= covered2;
        return n;
      },
      std::plus<size_t>());
  q.coverage = double(covered) / double(t.size());
  return q;
}

} // namespace mirage::surfels
