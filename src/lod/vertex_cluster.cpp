// simplifyClustered: the vertex-clustering fallback for stuck groups (see simplify.h and
// docs/lod.md, "Stuck groups").
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "mesh_prep.h"
#include "simplify.h"

namespace mirage::lod::detail {

namespace {

constexpr uint32_t kNil = ~0u;
// The result keeps the area within this fraction of the input's (the verifier allows 0.5 per
// group; the collapses before the fallback already moved it a little).
constexpr double kAreaTolerance = 0.4;
// Each step coarsens the grid by this factor: about 40 steps from one vertex per cell to one cell.
constexpr double kGridStep = 0.85;
// Topology changes look worse than the plane distance says (the same factor as clusterlod's sloppy
// fallback).
constexpr double kErrorFactor = 2.0;

using Tri = std::array<uint32_t, 3>;

uint64_t triKey(Tri t) {
  std::sort(t.begin(), t.end());
  return uint64_t(t[0]) << 42 | uint64_t(t[1]) << 21 | t[2];
}

// The group's triangles under merges of vertex sets into one of them. A merge is applied only when
// it keeps the DAG verifier's group rules for every edge it touches: the open edges stay those of
// the input, no edge gets more than two triangles unless the input's had as many, and the area
// stays within kAreaTolerance. Copies of one triangle (any winding) cancel in pairs, which keeps
// each edge's use parity, so closing a tunnel leaves no hole.
class Merger {
public:
  Merger(const SimplifyMesh& m, const std::vector<glm::dvec3>& p) : p_(p) {
    size_t nt = m.corners.size() / 3;
    incident_.resize(p.size());
    for (size_t t = 0; t < nt; ++t) {
      Tri v{m.corners[t * 3], m.corners[t * 3 + 1], m.corners[t * 3 + 2]};
      Tri a{m.attributes[t * 3], m.attributes[t * 3 + 1], m.attributes[t * 3 + 2]};
      addTriangle(v, a);
      for (size_t k = 0; k < 3; ++k) ++input_[edgeKey(v[k], v[(k + 1) % 3])];
    }
    edges_ = input_;
    areaBefore_ = area_;
    stamp_.assign(tris_.size(), 0);
  }

  size_t alive() const { return alive_; }
  const std::vector<Tri>& tris() const { return tris_; }
  const std::vector<Tri>& attrs() const { return attrs_; }
  bool isAlive(uint32_t t) const { return live_[t] != 0; }
  const std::vector<uint32_t>& incident(uint32_t v) const { return incident_[v]; }
  uint32_t inputUses(uint64_t e) const {
    auto it = input_.find(e);
    return it == input_.end() ? 0 : it->second;
  }

  // Merges `set` into r (a member; its attribute vertex `attribute` for moved corners). False, and
  // nothing changed, when the result would break a rule.
  bool merge(const std::vector<uint32_t>& set, uint32_t r, uint32_t attribute) {
    ++gen_;
    affected_.clear();
    for (uint32_t v : set)
      if (v != r)
        for (uint32_t t : incident_[v])
          if (live_[t] && stamp_[t] != gen_) stamp_[t] = gen_, affected_.push_back(t);
    delta_.clear();
    double areaDelta = 0.0;
    auto edgesOf = [&](const Tri& v, int sign) {
      for (size_t k = 0; k < 3; ++k) delta_.push_back({edgeKey(v[k], v[(k + 1) % 3]), sign});
    };
    for (uint32_t t : affected_) edgesOf(tris_[t], -1), areaDelta -= triArea(tris_[t]);
    // Remapped triangles by key; existing copies outside the affected set cancel with them.
    made_.clear();
    for (uint32_t t : affected_) {
      Tri v = tris_[t], a = attrs_[t];
      for (size_t k = 0; k < 3; ++k)
        if (v[k] != r && std::find(set.begin(), set.end(), v[k]) != set.end()) v[k] = r, a[k] = attribute;
      if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) continue;
      made_.push_back({triKey(v), v, a});
    }
    std::sort(made_.begin(), made_.end(), [](const Made& x, const Made& y) { return x.key < y.key; });
    cancelled_.clear();
    kept_.clear();
    for (size_t i = 0; i < made_.size();) {
      size_t j = i;
      while (j < made_.size() && made_[j].key == made_[i].key) ++j;
      std::vector<uint32_t> existing;
      if (auto it = byKey_.find(made_[i].key); it != byKey_.end())
        for (uint32_t t : it->second)
          if (live_[t] && stamp_[t] != gen_) existing.push_back(t);
      size_t total = existing.size() + (j - i);
      if (total % 2 == 1 && !existing.empty()) {
        for (size_t k = 1; k < existing.size(); ++k) cancelled_.push_back(existing[k]);
      } else {
        for (uint32_t t : existing) cancelled_.push_back(t);
        if (total % 2 == 1) kept_.push_back(i);
      }
      i = j;
    }
    for (uint32_t t : cancelled_) edgesOf(tris_[t], -1), areaDelta -= triArea(tris_[t]);
    for (size_t i : kept_) edgesOf(made_[i].v, +1), areaDelta += triArea(made_[i].v);
    if (std::abs(area_ + areaDelta - areaBefore_) > kAreaTolerance * areaBefore_) return false;
    std::sort(delta_.begin(), delta_.end());
    for (size_t i = 0; i < delta_.size();) {
      size_t j = i;
      int32_t d = 0;
      for (; j < delta_.size() && delta_[j].first == delta_[i].first; ++j) d += delta_[j].second;
      uint64_t e = delta_[i].first;
      auto it = edges_.find(e);
      int64_t after = int64_t(it == edges_.end() ? 0 : it->second) + d;
      uint32_t in = inputUses(e);
      if ((after == 1) != (in == 1) || (after > 2 && after > int64_t(in))) return false;
      i = j;
    }
    // Commit.
    for (uint32_t t : affected_) kill(t);
    for (uint32_t t : cancelled_) kill(t);
    for (size_t i : kept_) addTriangle(made_[i].v, made_[i].a);
    stamp_.resize(tris_.size(), 0);
    for (auto [e, d] : delta_) edges_[e] += uint32_t(d);
    return true;
  }

  double area() const { return area_; }

private:
  struct Made {
    uint64_t key;
    Tri v, a;
  };

  double triArea(const Tri& v) const { return 0.5 * glm::length(glm::cross(p_[v[1]] - p_[v[0]], p_[v[2]] - p_[v[0]])); }
  void addTriangle(const Tri& v, const Tri& a) {
    uint32_t t = uint32_t(tris_.size());
    tris_.push_back(v), attrs_.push_back(a), live_.push_back(1);
    for (uint32_t x : v) incident_[x].push_back(t);
    byKey_[triKey(v)].push_back(t);
    area_ += triArea(v);
    ++alive_;
  }
  void kill(uint32_t t) {
    live_[t] = 0;
    area_ -= triArea(tris_[t]);
    --alive_;
  }

  const std::vector<glm::dvec3>& p_;
  std::vector<Tri> tris_, attrs_;
  std::vector<uint8_t> live_;
  std::vector<std::vector<uint32_t>> incident_;
  std::unordered_map<uint64_t, uint32_t> input_, edges_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> byKey_;
  std::vector<uint32_t> stamp_, affected_, cancelled_;
  std::vector<size_t> kept_;
  std::vector<Made> made_;
  std::vector<std::pair<uint64_t, int32_t>> delta_;
  uint32_t gen_ = 0;
  size_t alive_ = 0;
  double area_ = 0.0, areaBefore_ = 0.0;
};

} // namespace

float simplifyClustered(SimplifyMesh& mesh, size_t targetTriangles) {
  size_t nv = mesh.positions.size(), nt = mesh.corners.size() / 3;
  if (nt == 0 || nt <= targetTriangles || nv >= (size_t(1) << 21)) return -1.0f;
  glm::dvec3 center(0.0);
  for (glm::vec3 p : mesh.positions) center += glm::dvec3(p);
  center /= double(nv);
  std::vector<glm::dvec3> p(nv);
  for (size_t i = 0; i < nv; ++i) p[i] = glm::dvec3(mesh.positions[i]) - center; // well conditioned
  Merger merger(mesh, p);
  // Movable: not locked and not on the group's open border (moving it would change the border the
  // neighbours and the parents share).
  std::vector<uint8_t> fixed(mesh.locked.begin(), mesh.locked.end());
  std::vector<Quadric> q(nv);
  std::vector<uint32_t> attributeOf(nv, kNil); // an attribute vertex at each position
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* v = &mesh.corners[t * 3];
    for (size_t k = 0; k < 3; ++k) {
      if (attributeOf[v[k]] == kNil) attributeOf[v[k]] = mesh.attributes[t * 3 + k];
      if (merger.inputUses(edgeKey(v[k], v[(k + 1) % 3])) == 1) fixed[v[k]] = fixed[v[(k + 1) % 3]] = 1;
    }
    glm::dvec3 n = glm::cross(p[v[1]] - p[v[0]], p[v[2]] - p[v[0]]);
    double len = glm::length(n);
    if (len <= 0.0) continue;
    n /= len;
    Quadric pq = planeQuadric(n, -glm::dot(n, p[v[0]]), len * 0.5);
    for (size_t k = 0; k < 3; ++k) add(q[v[k]], pq);
  }
  std::vector<uint8_t> merged(nv, 0);
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  size_t movable = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (!fixed[v] && attributeOf[v] != kNil) ++movable, lo = glm::min(lo, p[v]), hi = glm::max(hi, p[v]);
  double extent = movable >= 2 ? std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) : 0.0;
  if (!(extent > 0.0)) return -1.0f;

  std::vector<uint32_t> parent(nv), members;
  std::vector<uint64_t> cellOf(nv);
  auto find = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  struct Candidate {
    double error; // cell quadric distance² at the representative
    uint32_t root, rep;
  };
  std::vector<Candidate> candidates;
  std::vector<std::pair<uint32_t, uint32_t>> byRoot;
  double maxError = 0.0;
  // From about four cells per movable vertex's spacing on a surface down to one cell.
  for (double grid = std::ceil(std::sqrt(double(movable))) * 4.0; grid >= 1.0 && merger.alive() > targetTriangles;
       grid = std::min(grid - 1.0, std::floor(grid * kGridStep))) {
    double cell = extent / grid;
    for (uint32_t v = 0; v < nv; ++v) {
      parent[v] = v;
      glm::dvec3 c = glm::clamp(glm::floor((p[v] - lo) / cell), glm::dvec3(0.0), glm::dvec3(grid - 1.0));
      cellOf[v] = uint64_t(c.x) << 42 | uint64_t(c.y) << 21 | uint64_t(c.z);
    }
    // Only vertices connected inside their cell merge: gluing separate sheets that share a cell
    // would make edges of four triangles.
    for (uint32_t t = 0; t < merger.tris().size(); ++t) {
      if (!merger.isAlive(t)) continue;
      const Tri& v = merger.tris()[t];
      for (size_t k = 0; k < 3; ++k) {
        uint32_t a = v[k], b = v[(k + 1) % 3];
        if (fixed[a] || fixed[b] || cellOf[a] != cellOf[b]) continue;
        a = find(a), b = find(b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    }
    byRoot.clear();
    for (uint32_t v = 0; v < nv; ++v)
      if (!fixed[v] && !merged[v] && attributeOf[v] != kNil) byRoot.push_back({find(v), v});
    std::sort(byRoot.begin(), byRoot.end());
    candidates.clear();
    for (size_t i = 0; i < byRoot.size();) {
      size_t j = i;
      Quadric sum;
      while (j < byRoot.size() && byRoot[j].first == byRoot[i].first) add(sum, q[byRoot[j++].second]);
      if (j - i >= 2 && sum.w > 0.0) {
        Candidate c{std::numeric_limits<double>::max(), byRoot[i].first, byRoot[i].second};
        for (size_t k = i; k < j; ++k) {
          double e = std::max(eval(sum, p[byRoot[k].second]), 0.0) / sum.w;
          if (e < c.error) c.error = e, c.rep = byRoot[k].second;
        }
        candidates.push_back(c);
      }
      i = j;
    }
    // Cheapest merges first.
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      return a.error < b.error || (a.error == b.error && a.root < b.root);
    });
    for (const Candidate& c : candidates) {
      if (merger.alive() <= targetTriangles) break;
      members.clear();
      auto first = std::lower_bound(byRoot.begin(), byRoot.end(), std::pair<uint32_t, uint32_t>{c.root, 0});
      for (auto it = first; it != byRoot.end() && it->first == c.root; ++it) members.push_back(it->second);
      if (!merger.merge(members, c.rep, attributeOf[c.rep])) continue;
      for (uint32_t v : members)
        if (v != c.rep) merged[v] = 1, add(q[c.rep], q[v]);
      maxError = std::max(maxError, c.error);
    }
  }
  if (merger.alive() >= nt) return -1.0f;
  mesh.corners.clear();
  mesh.attributes.clear();
  for (uint32_t t = 0; t < merger.tris().size(); ++t)
    if (merger.isAlive(t))
      for (size_t k = 0; k < 3; ++k)
        mesh.corners.push_back(merger.tris()[t][k]), mesh.attributes.push_back(merger.attrs()[t][k]);
  return float(kErrorFactor * std::sqrt(maxError));
}

} // namespace mirage::lod::detail
