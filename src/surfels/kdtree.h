#pragma once
// A static 3D kd-tree over a point array (median splits, buckets of 16): radius and nearest queries
// for the CPU reference sampler and the quality metrics. Private to mirage_surfels.
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace mirage::surfels {

class KdTree {
public:
  explicit KdTree(std::span<const glm::vec3> points);

  // Calls visit(index, squaredDistance) for every point strictly closer than `radius` to q.
  template <class F> void forEachWithin(glm::vec3 q, float radius, F&& visit) const {
    if (!nodes_.empty()) within(0, q, radius * radius, visit);
  }
  // Squared distance from q to the nearest point other than `exclude` (infinity when none).
  float nearestSquared(glm::vec3 q, uint32_t exclude = UINT32_MAX) const;
  // Squared distance from q to its k-th nearest point other than `exclude` (infinity when fewer).
  float kthNearestSquared(glm::vec3 q, uint32_t k, uint32_t exclude = UINT32_MAX) const;
  // Point indices in leaf order: neighbours in space are neighbours here, so queries issued in this
  // order hit warm caches (a scan shuffled in memory otherwise misses on every leaf).
  std::span<const uint32_t> treeOrder() const { return order_; }

private:
  struct Node {
    uint32_t begin = 0, end = 0;  // range of order_ (leaves)
    uint32_t left = 0, right = 0; // children (inner nodes); left == 0 marks a leaf
    float split = 0.0f;
    uint32_t axis = 0;
  };
  void build(uint32_t index, uint32_t begin, uint32_t end);
  void nearest(uint32_t node, glm::vec3 q, uint32_t exclude, float& best) const;
  void kNearest(uint32_t node, glm::vec3 q, uint32_t k, uint32_t exclude, std::vector<float>& heap) const;
  template <class F> void within(uint32_t n, glm::vec3 q, float r2, F& visit) const {
    const Node& node = nodes_[n];
    if (node.left == 0) {
      for (uint32_t i = node.begin; i < node.end; ++i) {
        glm::vec3 d = sorted_[i] - q;
        float d2 = glm::dot(d, d);
        if (d2 < r2) visit(order_[i], d2);
      }
      return;
    }
    float diff = q[node.axis] - node.split;
    uint32_t nearChild = diff < 0.0f ? node.left : node.right;
    uint32_t farChild = diff < 0.0f ? node.right : node.left;
    within(nearChild, q, r2, visit);
    if (diff * diff < r2) within(farChild, q, r2, visit);
  }

  std::span<const glm::vec3> points_;
  std::vector<uint32_t> order_;
  std::vector<glm::vec3> sorted_; // points_[order_[i]]: leaves read contiguous memory
  std::vector<Node> nodes_;
};

} // namespace mirage::surfels
