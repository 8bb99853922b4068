#include "kdtree.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <utility>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace mirage::surfels {

namespace {
constexpr uint32_t kLeafSize = 16; // small buckets: queries in the sampler are tiny spheres
}

// Leaves of the subtrees over n and n + 1 points (median splits down to kLeafSize), in O(log n):
// below the root the sizes are ⌊n/2⌋ and ⌈n/2⌉, so both follow from the pair for ⌊n/2⌋.
std::pair<uint32_t, uint32_t> leafPair(uint32_t n) {
  if (n <= kLeafSize) return {1u, n + 1 <= kLeafSize ? 1u : 2u};
  auto [a, b] = leafPair(n / 2); // leaves(m), leaves(m + 1) with m = ⌊n/2⌋
  return n % 2 == 0 ? std::pair{2 * a, a + b} : std::pair{a + b, 2 * b};
}

// Nodes of the subtree over `count` points: the tree is laid out depth-first, so a node's right
// child sits after its whole left subtree.
uint32_t subtreeNodes(uint32_t count) { return 2 * leafPair(count).first - 1; }

KdTree::KdTree(std::span<const glm::vec3> points) : points_(points), order_(points.size()) {
  std::iota(order_.begin(), order_.end(), 0u);
  if (!points.empty()) {
    nodes_.resize(subtreeNodes(uint32_t(points.size())));
    build(0, 0, uint32_t(points.size()));
  }
  sorted_.resize(points.size());
  tbb::parallel_for(size_t(0), points.size(), [&](size_t i) { sorted_[i] = points_[order_[i]]; });
}

// Subtrees of large ranges are built in parallel: each writes its own slots of nodes_ and its own
// range of order_, so the tree is the same as a serial build's (tests compare against brute force).
void KdTree::build(uint32_t index, uint32_t begin, uint32_t end) {
  nodes_[index] = {begin, end};
  if (end - begin <= kLeafSize) return;
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (uint32_t i = begin; i < end; ++i) lo = glm::min(lo, points_[order_[i]]), hi = glm::max(hi, points_[order_[i]]);
  glm::vec3 e = hi - lo;
  uint32_t axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
  uint32_t mid = begin + (end - begin) / 2;
  // Ties on the axis are broken by index, so the tree (and every query order) is deterministic.
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end, [&](uint32_t a, uint32_t b) {
    float pa = points_[a][axis], pb = points_[b][axis];
    return pa < pb || (pa == pb && a < b);
  });
  Node& n = nodes_[index];
  n.left = index + 1;
  n.right = index + 1 + subtreeNodes(mid - begin);
  n.split = points_[order_[mid]][axis];
  n.axis = axis;
  uint32_t left = n.left, right = n.right;
  if (end - begin >= (1u << 16))
    tbb::parallel_invoke([&] { build(left, begin, mid); }, [&] { build(right, mid, end); });
  else
    build(left, begin, mid), build(right, mid, end);
}

void KdTree::nearest(uint32_t n, glm::vec3 q, uint32_t exclude, float& best) const {
  const Node& node = nodes_[n];
  if (node.left == 0) {
    for (uint32_t i = node.begin; i < node.end; ++i) {
      if (order_[i] == exclude) continue;
      glm::vec3 d = sorted_[i] - q;
      best = std::min(best, glm::dot(d, d));
    }
    return;
  }
  // Points equal to the split value sit on both sides of `mid`, hence <= on the far-side test.
  float diff = q[node.axis] - node.split;
  nearest(diff < 0.0f ? node.left : node.right, q, exclude, best);
  if (diff * diff <= best) nearest(diff < 0.0f ? node.right : node.left, q, exclude, best);
}

// `heap` is a max-heap of the k smallest squared distances so far; its top bounds the search.
void KdTree::kNearest(uint32_t n, glm::vec3 q, uint32_t k, uint32_t exclude, std::vector<float>& heap) const {
  const Node& node = nodes_[n];
  if (node.left == 0) {
    for (uint32_t i = node.begin; i < node.end; ++i) {
      if (order_[i] == exclude) continue;
      glm::vec3 d = sorted_[i] - q;
      float d2 = glm::dot(d, d);
      if (heap.size() < k) {
        heap.push_back(d2);
        std::push_heap(heap.begin(), heap.end());
      } else if (d2 < heap.front()) {
        std::pop_heap(heap.begin(), heap.end());
        heap.back() = d2;
        std::push_heap(heap.begin(), heap.end());
      }
    }
    return;
  }
  float diff = q[node.axis] - node.split;
  kNearest(diff < 0.0f ? node.left : node.right, q, k, exclude, heap);
  if (heap.size() < k || diff * diff <= heap.front())
    kNearest(diff < 0.0f ? node.right : node.left, q, k, exclude, heap);
}

float KdTree::kthNearestSquared(glm::vec3 q, uint32_t k, uint32_t exclude) const {
  thread_local std::vector<float> heap; // one allocation per thread, not per query
  heap.clear();
  if (!nodes_.empty() && k > 0) kNearest(0, q, k, exclude, heap);
  return heap.size() == k && k > 0 ? heap.front() : std::numeric_limits<float>::infinity();
}

float KdTree::nearestSquared(glm::vec3 q, uint32_t exclude) const {
  float best = std::numeric_limits<float>::infinity();
  if (!nodes_.empty()) nearest(0, q, exclude, best);
  return best;
}

} // namespace mirage::surfels
