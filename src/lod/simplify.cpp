#include "simplify.h"

#include <algorithm>
#include <cmath>
#include <queue>

namespace mirage::lod::detail {

namespace {

constexpr uint32_t kNil = ~0u;
// Border planes keep open borders (the mesh's own) from shrinking or drifting; meshoptimizer uses
// a similar boost for its border edges.
constexpr double kBorderWeight = 4.0;
// A collapse may turn a triangle by at most ~78 degrees (cos = 0.2): larger turns are folds.
constexpr double kFlipCos = 0.2;

struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0, w = 0;

  static Quadric plane(glm::dvec3 n, double d, double weight) {
    Quadric q;
    q.a00 = weight * n.x * n.x, q.a01 = weight * n.x * n.y, q.a02 = weight * n.x * n.z;
    q.a11 = weight * n.y * n.y, q.a12 = weight * n.y * n.z, q.a22 = weight * n.z * n.z;
    q.b0 = weight * n.x * d, q.b1 = weight * n.y * d, q.b2 = weight * n.z * d;
    q.c = weight * d * d;
    q.w = weight;
    return q;
  }
  void add(const Quadric& o) {
    a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
    b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c, w += o.w;
  }
  // Sum of weighted squared plane distances at p.
  double eval(glm::dvec3 p) const {
    double rx = a00 * p.x + a01 * p.y + a02 * p.z + b0;
    double ry = a01 * p.x + a11 * p.y + a12 * p.z + b1;
    double rz = a02 * p.x + a12 * p.y + a22 * p.z + b2;
    return rx * p.x + ry * p.y + rz * p.z + b0 * p.x + b1 * p.y + b2 * p.z + c;
  }
};

struct Entry {
  float cost;
  uint32_t u, w, version;
  uint32_t time; // collapse clock when queued: w unchanged since then means the check still holds
  bool operator<(const Entry& o) const { return cost > o.cost; } // min-heap
};

class Simplifier {
public:
  explicit Simplifier(SimplifyMesh& m) : m_(m) {
    size_t nv = m.positions.size(), nt = m.corners.size() / 3;
    center_ = glm::dvec3(0.0);
    for (glm::vec3 p : m.positions) center_ += glm::dvec3(p);
    if (nv) center_ /= double(nv);
    p_.resize(nv);
    // Relative to the group centre so quadric sums stay well conditioned far from the origin.
    for (size_t i = 0; i < nv; ++i) p_[i] = glm::dvec3(m.positions[i]) - center_;
    head_.assign(nv, kNil);
    tail_.assign(nv, kNil);
    next_.assign(nt * 3, kNil);
    for (uint32_t c = uint32_t(nt * 3); c-- > 0;) {
      uint32_t v = m.corners[c];
      next_[c] = head_[v];
      if (head_[v] == kNil) tail_[v] = c;
      head_[v] = c;
    }
    alive_.assign(nt, 1);
    live_ = nt;
    version_.assign(nv, 0);
    dirty_.assign(nv, 0);
    changed_.assign(nv, 0);
    queued_.assign(nv, 0);
    q_.assign(nv, Quadric{});
    initQuadrics();
  }

  float run(size_t target) {
    for (uint32_t v = 0; v < p_.size(); ++v) push(v);
    while (live_ > target && !heap_.empty()) {
      Entry e = heap_.top();
      heap_.pop();
      if (e.version != version_[e.u] || head_[e.u] == kNil) continue;
      if (dirty_[e.u]) {
        // Lazy re-evaluation: collapses only raise costs (quadrics accumulate), so the stale cost
        // is a good lower bound and most dirty vertices are never evaluated again before the target.
        push(e.u);
        continue;
      }
      // u is clean, but w's triangles may have changed since this entry was queued: recheck then.
      if (changed_[e.w] > e.time && (gatherRing(e.u, ringU_), !legal(e.u, e.w))) {
        push(e.u);
        continue;
      }
      maxCost_ = std::max(maxCost_, double(std::max(e.cost, 0.0f)));
      collapse(e);
    }
    compact();
    return float(std::sqrt(maxCost_));
  }

private:
  template <class F> void forTriangles(uint32_t v, F&& f) {
    for (uint32_t c = head_[v]; c != kNil; c = next_[c])
      if (alive_[c / 3]) f(c / 3, c % 3);
  }

  void initQuadrics() {
    size_t nt = alive_.size();
    for (uint32_t t = 0; t < nt; ++t) {
      const uint32_t* v = &m_.corners[t * 3];
      glm::dvec3 a = p_[v[0]], b = p_[v[1]], c = p_[v[2]];
      glm::dvec3 n = glm::cross(b - a, c - a);
      double len = glm::length(n);
      if (len <= 0.0) continue;
      n /= len;
      Quadric q = Quadric::plane(n, -glm::dot(n, a), len * 0.5);
      for (int k = 0; k < 3; ++k) q_[v[k]].add(q);
    }
    // Open edges (used by one triangle here) get a plane through the edge, perpendicular to the face.
    std::vector<std::pair<uint64_t, uint32_t>> edges;
    edges.reserve(nt * 3);
    for (uint32_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) {
        uint32_t a = m_.corners[t * 3 + k], b = m_.corners[t * 3 + (k + 1) % 3];
        edges.push_back({a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a), t * 3 + k});
      }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j].first == edges[i].first) ++j;
      if (j - i == 1) {
        uint32_t c = edges[i].second, t = c / 3, k = c % 3;
        uint32_t a = m_.corners[c], b = m_.corners[t * 3 + (k + 1) % 3], o = m_.corners[t * 3 + (k + 2) % 3];
        glm::dvec3 e = p_[b] - p_[a];
        glm::dvec3 fn = glm::cross(e, p_[o] - p_[a]);
        glm::dvec3 n = glm::cross(e, fn);
        double len = glm::length(n);
        if (len > 0.0) {
          n /= len;
          Quadric q = Quadric::plane(n, -glm::dot(n, p_[a]), glm::dot(e, e) * kBorderWeight);
          q_[a].add(q);
          q_[b].add(q);
        }
      }
      i = j;
    }
  }

  // Other vertices of v's live triangles, two per triangle, sorted (multiplicity = edge use count).
  void gatherRing(uint32_t v, std::vector<uint32_t>& ring) {
    ring.clear();
    forTriangles(v, [&](uint32_t t, uint32_t k) {
      ring.push_back(m_.corners[t * 3 + (k + 1) % 3]);
      ring.push_back(m_.corners[t * 3 + (k + 2) % 3]);
    });
    std::sort(ring.begin(), ring.end());
  }

  static uint32_t multiplicity(const std::vector<uint32_t>& ring, uint32_t w) {
    auto r = std::equal_range(ring.begin(), ring.end(), w);
    return uint32_t(r.second - r.first);
  }

  // Candidate targets of u (ringU_ gathered): empty when u must stay.
  void candidates(uint32_t u, std::vector<uint32_t>& out) {
    out.clear();
    if (m_.locked[u] || ringU_.empty()) return;
    uint32_t borderEdges = 0;
    for (size_t i = 0; i < ringU_.size();) {
      size_t j = i;
      while (j < ringU_.size() && ringU_[j] == ringU_[i]) ++j;
      if (j - i > 2) return; // non-manifold edge: keep the vertex
      if (j - i == 1) ++borderEdges;
      i = j;
    }
    if (borderEdges != 0 && borderEdges != 2) return; // several borders meet: a complex vertex
    for (size_t i = 0; i < ringU_.size();) {
      size_t j = i;
      while (j < ringU_.size() && ringU_[j] == ringU_[i]) ++j;
      // A border vertex only slides along its border, so the border keeps its shape.
      if (borderEdges == 0 || j - i == 1) out.push_back(ringU_[i]);
      i = j;
    }
  }

  // Link condition (no pinched or duplicated triangles) and no folded triangles. ringU_ is u's ring.
  bool legal(uint32_t u, uint32_t w) {
    uint32_t edgeUse = multiplicity(ringU_, w);
    if (edgeUse == 0 || edgeUse > 2 || head_[w] == kNil) return false;
    gatherRing(w, ringW_);
    uint32_t common = 0;
    for (size_t i = 0, j = 0; i < ringU_.size() && j < ringW_.size();) {
      if (ringU_[i] < ringW_[j])
        ++i;
      else if (ringW_[j] < ringU_[i])
        ++j;
      else {
        uint32_t x = ringU_[i];
        ++common;
        while (i < ringU_.size() && ringU_[i] == x) ++i;
        while (j < ringW_.size() && ringW_[j] == x) ++j;
      }
    }
    if (common != edgeUse) return false;
    // The edge part of the link condition: a triangle (u, a, b) must not become a copy of an
    // existing (w, a, b), e.g. a valence-3 vertex over a closed tetrahedron or a folded-over flap.
    bool duplicate = false;
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      uint32_t a = m_.corners[t * 3 + (k + 1) % 3], b = m_.corners[t * 3 + (k + 2) % 3];
      if (duplicate || a == w || b == w || !multiplicity(ringW_, a) || !multiplicity(ringW_, b)) return;
      forTriangles(w, [&](uint32_t t2, uint32_t) {
        const uint32_t* v = &m_.corners[t2 * 3];
        bool hasA = v[0] == a || v[1] == a || v[2] == a, hasB = v[0] == b || v[1] == b || v[2] == b;
        duplicate |= hasA && hasB;
      });
    });
    if (duplicate) return false;
    // No new edge between two locked vertices: a neighbouring group may create the same chord
    // (e.g. along a straight border, as a zero-area sliver) and the edge would then join four
    // triangles. Edges that already exist are fine.
    if (m_.locked[w]) {
      for (size_t i = 0; i < ringU_.size(); ++i) {
        uint32_t x = ringU_[i];
        if (x != w && m_.locked[x] && (i == 0 || ringU_[i - 1] != x) && !multiplicity(ringW_, x)) return false;
      }
    }
    bool ok = true;
    glm::dvec3 pw = p_[w];
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      const uint32_t* v = &m_.corners[t * 3];
      if (!ok || v[0] == w || v[1] == w || v[2] == w) return;
      glm::dvec3 a = p_[v[(k + 1) % 3]], b = p_[v[(k + 2) % 3]];
      glm::dvec3 n0 = glm::cross(a - p_[u], b - p_[u]);
      glm::dvec3 n1 = glm::cross(a - pw, b - pw);
      double d = glm::dot(n0, n1);
      if (d < kFlipCos * glm::length(n0) * glm::length(n1) || (d <= 0.0 && glm::dot(n0, n0) > 0.0)) ok = false;
    });
    return ok;
  }

  double cost(uint32_t u, uint32_t w) const {
    Quadric q = q_[u];
    q.add(q_[w]);
    return q.w > 0.0 ? std::max(q.eval(p_[w]), 0.0) / q.w : 0.0;
  }

  // Re-evaluates v's cheapest legal collapse and queues it (older entries of v go stale).
  void push(uint32_t v) {
    ++version_[v];
    dirty_[v] = 0;
    queued_[v] = 0;
    if (head_[v] == kNil || m_.locked[v]) return;
    gatherRing(v, ringU_);
    candidates(v, cand_);
    if (cand_.empty()) return;
    scored_.clear();
    for (uint32_t w : cand_) scored_.push_back({cost(v, w), w});
    std::sort(scored_.begin(), scored_.end());
    for (auto [c, w] : scored_)
      if (legal(v, w)) {
        heap_.push({float(c), v, w, version_[v], clock_});
        queued_[v] = 1;
        return;
      }
  }

  // v's neighbourhood changed: re-evaluate it when its (stale) entry comes up; a vertex without
  // an entry gets one at the current cost level so it is looked at again soon.
  void markDirty(uint32_t v, float cost) {
    if (m_.locked[v] || head_[v] == kNil) return;
    dirty_[v] = 1;
    if (!queued_[v]) {
      heap_.push({cost, v, kNil, version_[v], clock_});
      queued_[v] = 1;
    }
  }

  void collapse(const Entry& e) {
    uint32_t u = e.u, w = e.w;
    // Attribute wedges: a corner of u takes the attribute w has in a dying triangle on the same
    // side of any attribute seam (same attribute at u), so UV charts stay consistent.
    pairs_.clear();
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      for (uint32_t j = 0; j < 3; ++j)
        if (m_.corners[t * 3 + j] == w) pairs_.push_back({m_.attributes[t * 3 + k], m_.attributes[t * 3 + j]});
    });
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      uint32_t* v = &m_.corners[t * 3];
      if (v[0] == w || v[1] == w || v[2] == w) {
        alive_[t] = 0;
        --live_;
        return;
      }
      v[k] = w;
      uint32_t& a = m_.attributes[t * 3 + k];
      uint32_t mapped = pairs_.empty() ? a : pairs_[0].second;
      for (auto [from, to] : pairs_)
        if (from == a) mapped = to;
      a = mapped;
    });
    q_[w].add(q_[u]);
    // w's corner list becomes its live corners plus u's: dropping dead ones keeps lists short.
    uint32_t first = kNil, last = kNil;
    for (uint32_t v : {w, u})
      for (uint32_t c = head_[v], n; c != kNil; c = n) {
        n = next_[c];
        if (!alive_[c / 3]) continue;
        (last == kNil ? first : next_[last]) = c;
        last = c;
      }
    if (last != kNil) next_[last] = kNil;
    head_[w] = first;
    tail_[w] = last;
    head_[u] = tail_[u] = kNil;
    ++version_[u];
    gatherRing(w, ringTouched_);
    ringTouched_.erase(std::unique(ringTouched_.begin(), ringTouched_.end()), ringTouched_.end());
    ++clock_;
    changed_[w] = clock_;
    for (uint32_t x : ringTouched_) changed_[x] = clock_;
    markDirty(w, e.cost);
    for (uint32_t x : ringTouched_) markDirty(x, e.cost);
  }

  void compact() {
    size_t out = 0;
    for (size_t t = 0; t < alive_.size(); ++t) {
      if (!alive_[t]) continue;
      for (int k = 0; k < 3; ++k) {
        m_.corners[out * 3 + k] = m_.corners[t * 3 + k];
        m_.attributes[out * 3 + k] = m_.attributes[t * 3 + k];
      }
      ++out;
    }
    m_.corners.resize(out * 3);
    m_.attributes.resize(out * 3);
  }

  SimplifyMesh& m_;
  glm::dvec3 center_;
  std::vector<glm::dvec3> p_;
  std::vector<uint32_t> head_, tail_, next_, version_, changed_;
  uint32_t clock_ = 0;
  std::vector<uint8_t> alive_, dirty_, queued_;
  std::vector<Quadric> q_;
  size_t live_ = 0;
  double maxCost_ = 0.0;
  std::priority_queue<Entry> heap_;
  std::vector<uint32_t> ringU_, ringW_, ringTouched_, cand_;
  std::vector<std::pair<double, uint32_t>> scored_;
  std::vector<std::pair<uint32_t, uint32_t>> pairs_;
};

} // namespace

float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles) {
  if (mesh.corners.size() / 3 <= targetTriangles) return 0.0f;
  Simplifier s(mesh);
  return s.run(targetTriangles);
}

} // namespace mirage::lod::detail
