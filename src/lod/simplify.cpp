#include "simplify.h"

#include <algorithm>
#include <cmath>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h> // AVX in functions compiled for it, picked when the CPU has it
#endif

namespace mirage::lod::detail {

namespace {

constexpr uint32_t kNil = ~0u;
constexpr uint32_t kUnchecked = ~0u; // time[v] of an entry whose legality was not tested yet
// Room for this many more corners in each vertex's list at set-up: a collapse onto w adds u's
// surviving corners and drops w's dead ones (about two more per collapse on a closed surface).
constexpr uint32_t kListSlack = 4;
// Border planes keep open borders (the mesh's own) from shrinking or drifting. Weight 1 (the
// face's own plane weight for a square face): 4 kept the bunny's holes' rims at the expense of its
// surface (LodQuality 1.6 %: 3.57e-4 at 4, 3.52e-4 at 1, groups of 32).
constexpr double kBorderWeight = 1.0;
// A collapse may turn a triangle by at most ~78 degrees (cos = 0.2): larger turns are folds.
constexpr double kFlipCos = 0.2;
// A face may turn at most ~75 degrees away from the mean shading normal of its corners.
constexpr double kShadingCos = 0.25;
// The collapse order sees the normal term at half the reported weight. Blind to it (0), collapses
// ruin the shading freely and the reported error explodes (the dragon's close view drew 636 k
// instead of 208 k triangles at tau 1 px); the full weight trades more geometric accuracy for
// normals (docs/lod.md, "Shading-aware error (the default)").
constexpr double kOrderNormalFraction = 0.5;

// The normal deviation counts up to this squared angle (0.3 rad, 17 degrees): a larger shading
// change is wrong either way, and the coarse levels (far, small on screen) would otherwise be ruled
// by it (2500 dragons at 1080p, tau 1 px: 11 % fewer triangles drawn; the close view unchanged).
constexpr double kMaxNormalDeviation2 = 0.3 * 0.3;

using HeapItem = SimplifyScratch::HeapItem;

constexpr uint32_t kNextCorner[3] = {1, 2, 0}, kPrevCorner[3] = {2, 0, 1};

void add(NormalQuadric& q, const NormalQuadric& o) {
  q.a += o.a, q.bx += o.bx, q.by += o.by, q.bz += o.bz, q.c += o.c, q.spread += o.spread;
}

// Σ a |m - n|² of the corners in q.
double deviation(const NormalQuadric& q, glm::dvec3 m) {
  return q.a * glm::dot(m, m) - 2.0 * (m.x * q.bx + m.y * q.by + m.z * q.bz) + q.c;
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx"), always_inline)) inline __m256d avxAdd(__m256d x, __m256d y) {
  return _mm256_add_pd(x, y);
}
__attribute__((target("avx"), always_inline)) inline __m256d avxMul(__m256d x, __m256d y) {
  return _mm256_mul_pd(x, y);
}
__attribute__((target("avx"), always_inline)) inline __m256d avxSelect(__m256d mask, __m256d yes, __m256d no) {
  return _mm256_or_pd(_mm256_and_pd(mask, yes), _mm256_andnot_pd(mask, no));
}
#endif

class Simplifier {
public:
  Simplifier(SimplifyMesh& m, SimplifyScratch& s) : m_(m), s_(s) {
    size_t nv = m.positions.size(), nt = m.corners.size() / 3;
    center_ = glm::dvec3(0.0);
    for (glm::vec3 p : m.positions) center_ += glm::dvec3(p);
    if (nv) center_ /= double(nv);
    s.p.resize(nv);
    // Relative to the group centre so quadric sums stay well conditioned far from the origin.
    for (size_t i = 0; i < nv; ++i) s.p[i] = glm::dvec3(m.positions[i]) - center_;
    // Corner lists in corner order, each with room to grow by a few collapses in place.
    s.listSize.assign(nv, 0);
    for (uint32_t v : m.corners) ++s.listSize[v];
    s.listStart.resize(nv);
    s.listCap.resize(nv);
    uint32_t room = 0;
    for (size_t v = 0; v < nv; ++v) {
      s.listStart[v] = room, s.listCap[v] = s.listSize[v] + kListSlack, room += s.listCap[v];
      s.listSize[v] = 0;
    }
    s.lists.reserve(size_t(room) * 2);
    s.lists.resize(room);
    for (uint32_t c = 0; c < uint32_t(nt * 3); ++c) {
      uint32_t v = m.corners[c];
      s.lists[s.listStart[v] + s.listSize[v]++] = c;
    }
    s.alive.assign(nt, 1);
    live_ = nt;
    s.dirty.assign(nv, 0);
    s.changed.assign(nv, 0);
    s.heapPos.assign(nv, kNil);
    s.target.assign(nv, kNil);
    s.time.assign(nv, kUnchecked);
    s.markU.assign(nv, 0);
    s.markW.assign(nv, 0);
    s.ringU.resize(nv);
    s.ringW.resize(nv);
    s.endsU.resize(nt * 6); // two ends per corner of a vertex (up to three corners per triangle)
    s.endsW.resize(nt * 6);
    s.cands.resize(nv);
    s.candCost.resize(nv);
    s.q.assign(nv, Quadric{});
    // The heap's children groups (4i + 1 .. 4i + 4) start on 32-byte boundaries, so the four
    // costs a sift compares share a cache line: entry 0 sits 8 bytes before such a boundary.
    s.heap.resize(nv + 4);
    heap_ = s.heap.data();
    while ((reinterpret_cast<uintptr_t>(heap_ + 1) & 31) != 0) ++heap_;
    heapSize_ = 0;
    double normalScale = double(m.normalWeight) * double(m.normalLength);
    normalWeight2_ = m.normals ? normalScale * normalScale : 0.0;
    orderWeight2_ = normalWeight2_ * kOrderNormalFraction * kOrderNormalFraction;
    initQuadrics();
  }

  float run(size_t target) {
    // Every vertex's cheapest collapse, then one heapify (deterministic: the order is the ids').
    savedRings_ = true;
    for (uint32_t v = 0; v < s_.p.size(); ++v) {
      float c = evaluate(v, true);
      if (c >= 0.0f) s_.heapPos[v] = heapSize_, heap_[heapSize_++] = {c, v};
    }
    savedRings_ = false;
    if (heapSize_ > 1)
      for (size_t i = (heapSize_ - 2) / 4 + 1; i-- > 0;) siftDown(uint32_t(i));
    while (live_ > target && heapSize_ != 0) {
      uint32_t u = heap_[0].v;
      if (s_.dirty[u]) {
        // Lazy re-evaluation: collapses mostly raise costs (quadrics accumulate), so the stale cost
        // is a good lower bound and many dirty vertices are never evaluated again before the target.
        requeue(u, true);
        continue;
      }
      uint32_t w = s_.target[u], checked = s_.time[u];
      // u is clean, but the entry was queued unchecked or w's triangles changed since.
      bool tested = checked == kUnchecked || s_.changed[w] > checked;
      if (tested && (gatherRingU(u), !legal(u, w))) {
        // The cheapest legal candidate instead; w was just refused (nothing changed since).
        knownIllegal_ = w;
        requeue(u, false);
        knownIllegal_ = kNil;
        continue;
      }
      // The reported error is the cost with the normal term at collapse time (w's quadrics may
      // have grown since the entry was queued).
      maxCost_ = std::max(maxCost_, cost(u, w, normalWeight2_));
      float queuedCost = heap_[0].cost;
      heapRemove(u);
      collapse(u, w, queuedCost, tested);
    }
    compact();
    return float(std::sqrt(maxCost_));
  }

private:
  // Distinct neighbours of a vertex with their edge use counts, valid while mark's stamp == gen.
  struct Ring {
    std::vector<uint32_t>& list; // sized to the vertex count once: no push_back in the hot loops
    std::vector<uint64_t>& mark; // gen << 32 | count
    uint32_t& gen;
    uint32_t& size;
    std::vector<uint32_t>& ends; // the other two corners of each live triangle, as gathered
    uint32_t& endCount;
    uint32_t uses(uint32_t x) const { return uint32_t(mark[x] >> 32) == gen ? uint32_t(mark[x]) : 0; }
    uint32_t count(uint32_t x) const { return uint32_t(mark[x]); } // x in the ring
    const uint32_t* begin() const { return list.data(); }
    const uint32_t* end() const { return list.data() + size; }
    void clear() { size = 0, ++gen; }
  };
  Ring ringU() { return {s_.ringU, s_.markU, genU_, sizeU_, s_.endsU, endsU_}; }
  Ring ringW() { return {s_.ringW, s_.markW, genW_, sizeW_, s_.endsW, endsW_}; }

  const uint32_t* cornersOf(uint32_t v) const { return s_.lists.data() + s_.listStart[v]; }
  bool hasCorners(uint32_t v) const { return s_.listSize[v] != 0; }

  template <class F> void forTriangles(uint32_t v, F&& f) {
    const uint32_t* list = cornersOf(v);
    for (uint32_t i = 0, n = s_.listSize[v]; i < n; ++i) {
      uint32_t c = list[i], t = c / 3;
      if (s_.alive[t]) f(t, c - t * 3);
    }
  }

  // Like forTriangles, while f returns true; false when f stopped the walk.
  template <class F> bool allTriangles(uint32_t v, F&& f) {
    const uint32_t* list = cornersOf(v);
    for (uint32_t i = 0, n = s_.listSize[v]; i < n; ++i) {
      uint32_t c = list[i], t = c / 3;
      if (s_.alive[t] && !f(t, c - t * 3)) return false;
    }
    return true;
  }

  // Plane quadrics scattered from the triangles; normal quadrics and rings in one pass over the
  // vertices: each vertex sums its corners' normal terms in registers while it gathers its ring,
  // walking its corner list, which is in triangle order, so the sums are the ones a scatter over
  // the triangles gives, bit for bit, without its read-modify-writes of 9 values per corner.
  // (Gathering the plane quadrics the same way, from one stored per triangle, ran fewer
  // instructions but streamed 88 more bytes per triangle through the cache: more misses.)
  void initQuadrics() {
    size_t nt = s_.alive.size(), nv = s_.p.size();
    const uint32_t* corners = m_.corners.data();
    const bool normals = normalWeight2_ > 0.0;
    s_.triLen.resize(nt);
    for (uint32_t t = 0; t < nt; ++t) {
      const uint32_t* v = &corners[t * 3];
      // Attribute ids are the input's (scattered over the whole normal array): fetch ahead, so the
      // vertex pass finds them in cache.
      if (normals && t + 8 < nt)
        for (int k = 0; k < 3; ++k) __builtin_prefetch(&m_.normals[m_.attributes[(t + 8) * 3 + k]]);
      glm::dvec3 a = s_.p[v[0]], b = s_.p[v[1]], c = s_.p[v[2]];
      glm::dvec3 n = glm::cross(b - a, c - a);
      double len = glm::length(n);
      s_.triLen[t] = len; // <= 0: degenerate, no plane and no normal term
      if (len <= 0.0) continue;
      n /= len;
      Quadric q = planeQuadric(n, -glm::dot(n, a), len * 0.5);
      for (int k = 0; k < 3; ++k) add(s_.q[v[k]], q);
    }
    if (normals) {
      s_.nq.resize(nv);
      s_.normal.resize(nv + 1); // one spare: orderCostsAvx loads each normal as four floats
    }
    // The rings are kept (flat) for the first evaluation of every vertex in run(); open edges (used
    // by one triangle) are found on them, once per edge from its lower end, and get their planes
    // after every vertex has its triangles' (the order of a scatter over triangles, then edges).
    s_.ringStart.resize(nv + 1);
    s_.ringNbr.resize(nt * 6); // a ring has at most two entries per corner
    s_.ringCnt.resize(nt * 6);
    s_.openEdges.clear();
    const double* triLen = s_.triLen.data();
    const uint32_t* attributes = m_.attributes.data();
    const glm::vec3* inputNormals = m_.normals;
    uint32_t* ends = s_.endsW.data();
    uint64_t* mark = s_.markW.data();
    uint32_t saved = 0;
    for (uint32_t a = 0; a < nv; ++a) {
      const uint32_t* cl = cornersOf(a);
      uint32_t size = s_.listSize[a], n = 0;
      NormalQuadric nq;
      glm::vec3 normal(0.0f);
      for (uint32_t i = 0; i < size; ++i) {
        uint32_t c = cl[i], t = c / 3, base = t * 3, k = c - base;
        ends[n] = corners[base + kNextCorner[k]];
        ends[n + 1] = corners[base + kPrevCorner[k]];
        n += 2;
      }
      if (normals) {
        for (uint32_t i = 0; i < size; ++i) {
          uint32_t c = cl[i];
          double len = triLen[c / 3];
          if (len <= 0.0) continue;
          double area = len * (0.5 / 3.0);
          glm::dvec3 vn = glm::dvec3(inputNormals[attributes[c]]);
          add(nq, {area, area * vn.x, area * vn.y, area * vn.z, area * glm::dot(vn, vn)});
          normal += glm::vec3(vn * area);
        }
        float nlen = glm::length(normal);
        normal = nlen > 0.0f ? normal / nlen : glm::vec3(0.0f);
        nq.spread = std::max(deviation(nq, glm::dvec3(normal)), 0.0);
        s_.nq[a] = nq, s_.normal[a] = normal;
      }
      // Distinct neighbours in first-seen order with their edge use counts (as gatherRing).
      s_.ringStart[a] = saved;
      uint32_t* nbr = s_.ringNbr.data();
      saved += distinctEnds(ends, n, mark, uint64_t(++genW_) << 32, nbr + saved);
      for (uint32_t j = s_.ringStart[a]; j < saved; ++j) {
        uint32_t b = nbr[j], count = uint32_t(mark[b]);
        s_.ringCnt[j] = count;
        if (b > a && count == 1) s_.openEdges.push_back({a, b});
      }
    }
    s_.ringStart[nv] = saved;
    sizeW_ = 0; // ringW holds no vertex's ring now
    for (const std::pair<uint32_t, uint32_t>& edge : s_.openEdges) {
      uint32_t a = edge.first, b = edge.second; // plain locals: clang 14 cannot capture bindings
      uint32_t o = kNil;
      forTriangles(a, [&](uint32_t t, uint32_t k) {
        uint32_t x = corners[t * 3 + (k + 1) % 3], y = corners[t * 3 + (k + 2) % 3];
        if (x == b || y == b) o = x == b ? y : x;
      });
      glm::dvec3 e = s_.p[b] - s_.p[a];
      glm::dvec3 fn = glm::cross(e, s_.p[o] - s_.p[a]);
      glm::dvec3 n = glm::cross(e, fn);
      double len = glm::length(n);
      if (len > 0.0) {
        n /= len;
        Quadric q = planeQuadric(n, -glm::dot(n, s_.p[a]), glm::dot(e, e) * kBorderWeight);
        add(s_.q[a], q);
        add(s_.q[b], q);
      }
    }
    s_.onto.resize(nv);
    for (uint32_t v = 0; v < nv; ++v) {
      SimplifyScratch::Target& t = s_.onto[v];
      t.p = s_.p[v], t.selfCost = eval(s_.q[v], s_.p[v]), t.weight = s_.q[v].w;
      // selfDev starts at 0: v's own normal quadric at its own normal less its spread.
      t.area = normals ? s_.nq[v].a : 0.0, t.selfDev = 0.0;
    }
  }

  // Also drops v's dead corners (triangles removed by neighbouring collapses), so later walks
  // over v's list are shorter; the order of the live corners stays.
  void gatherRing(uint32_t v, Ring r) {
    r.clear();
    const uint32_t* corners = m_.corners.data();
    const uint8_t* alive = s_.alive.data();
    uint32_t* ends = r.ends.data();
    uint32_t n = 0, live = 0;
    uint32_t* cl = s_.lists.data() + s_.listStart[v];
    for (uint32_t i = 0, size = s_.listSize[v]; i < size; ++i) {
      // Branch-free: a dead triangle's entries are written and then overwritten.
      uint32_t c = cl[i], t = c / 3, base = t * 3, k = c - base, keep = alive[t];
      cl[live] = c;
      ends[n] = corners[base + kNextCorner[k]];
      ends[n + 1] = corners[base + kPrevCorner[k]];
      live += keep, n += keep * 2;
    }
    s_.listSize[v] = live;
    // Distinct neighbours in first-seen order with their use counts.
    r.size = distinctEnds(ends, n, r.mark.data(), uint64_t(r.gen) << 32, r.list.data());
    r.endCount = n;
  }

  // The distinct ends among ends[0..n) (n even: two per triangle) into list, in first-seen order,
  // with mark[x] = stamped | uses of x; returns how many. Without a "seen before?" branch per end
  // (a coin flip): stamp and zero every end first, then count. Two ends a step.
  static uint32_t distinctEnds(const uint32_t* ends, uint32_t n, uint64_t* mark, uint64_t stamped, uint32_t* list) {
    for (uint32_t i = 0; i < n; i += 2) mark[ends[i]] = stamped, mark[ends[i + 1]] = stamped;
    uint32_t size = 0;
    for (uint32_t i = 0; i < n; i += 2) {
      uint32_t x = ends[i], y = ends[i + 1];
      uint64_t m = mark[x];
      mark[x] = m + 1;
      list[size] = x;
      size += uint32_t(m) == 0;
      m = mark[y];
      mark[y] = m + 1;
      list[size] = y;
      size += uint32_t(m) == 0;
    }
    return size;
  }

  // ringU = v's ring. Skipped when ringU already holds it and nothing collapsed since: a dirty
  // vertex re-evaluated at the top of the heap often stays there and is tested next.
  void gatherRingU(uint32_t v) {
    if (ringUOf_ == v && ringUClock_ == clock_) return;
    gatherRing(v, ringU());
    ringUOf_ = v, ringUClock_ = clock_;
  }

  // Link condition (no pinched or duplicated triangles) and no folded triangles. ringU is u's ring.
  // A pure test: the order of its parts only decides how soon a failure is found. Folds (and, with
  // normals, shading turns) are most of the failures, and they need only u's triangles (the ends
  // gathered with ringU), so they go before gathering w's ring.
  bool legal(uint32_t u, uint32_t w) {
    Ring ru = ringU(), rw = ringW();
    uint32_t edgeUse = ru.uses(w);
    if (edgeUse == 0 || edgeUse > 2 || !hasCorners(w)) return false;
    const uint32_t* ends = s_.endsU.data();
    uint32_t n = endsU_;
    glm::dvec3 pu = s_.p[u], pw = s_.p[w];
    for (uint32_t i = 0; i < n; i += 2) {
      uint32_t a = ends[i], b = ends[i + 1];
      if (a == w || b == w) continue;
      glm::dvec3 pa = s_.p[a], pb = s_.p[b];
      glm::dvec3 n0 = glm::cross(pa - pu, pb - pu);
      glm::dvec3 n1 = glm::cross(pa - pw, pb - pw);
      double d = glm::dot(n0, n1), l0 = glm::dot(n0, n0);
      // No fold: d < cos * |n0| |n1| without square roots; a degenerate n0 never blocks.
      if (d <= 0.0 ? l0 > 0.0 : d * d < kFlipCos * kFlipCos * l0 * glm::dot(n1, n1)) return false;
      // With normals: the new face must stay within ~75 degrees of the shading normals at its
      // corners (small turns per collapse add up to folds whose back faces show near silhouettes).
      if (normalWeight2_ > 0.0 && l0 > 0.0) {
        glm::dvec3 shading = glm::dvec3(s_.normal[w] + s_.normal[a] + s_.normal[b]);
        double f = glm::dot(n1, shading);
        if (f <= 0.0 || f * f < kShadingCos * kShadingCos * glm::dot(n1, n1) * glm::dot(shading, shading)) return false;
      }
    }
    gatherRing(w, rw);
    uint32_t common = 0;
    for (uint32_t x : rw) common += ru.uses(x) != 0;
    if (common != edgeUse) return false;
    // No new edge between two locked vertices: a neighbouring group may create the same chord
    // (e.g. along a straight border, as a zero-area sliver) and the edge would then join four
    // triangles. Edges that already exist are fine.
    if (m_.locked[w])
      for (uint32_t x : ru)
        if (x != w && m_.locked[x] && !rw.uses(x)) return false;
    // The edge part of the link condition: a triangle (u, a, b) must not become a copy of an
    // existing (w, a, b), e.g. a valence-3 vertex over a closed tetrahedron or a folded-over flap.
    for (uint32_t i = 0; i < n; i += 2) {
      uint32_t a = ends[i], b = ends[i + 1];
      if (a == w || b == w || !rw.uses(a) || !rw.uses(b)) continue;
      if (!allTriangles(w, [&](uint32_t t2, uint32_t) {
            const uint32_t* x = &m_.corners[t2 * 3];
            bool hasA = x[0] == a || x[1] == a || x[2] == a, hasB = x[0] == b || x[1] == b || x[2] == b;
            return !(hasA && hasB);
          }))
        return false;
    }
    return true;
  }

  // The normal term of collapsing u onto w as Σ a·|m_w − n|² less the merged spread (dev · area)
  // and the area: w's share is cached in onto[w].selfDev (it changes only when w's quadric grows).
  std::pair<double, double> normalDeviation(uint32_t u, uint32_t w) const {
    const NormalQuadric& nu = s_.nq[u];
    const SimplifyScratch::Target& t = s_.onto[w];
    return {t.selfDev + deviation(nu, glm::dvec3(s_.normal[w])) - nu.spread, nu.a + t.area};
  }

  double cost(uint32_t u, uint32_t w, double normalWeight2) const {
    const Quadric& qu = s_.q[u];
    const SimplifyScratch::Target& t = s_.onto[w];
    double weight = qu.w + t.weight;
    // (Q_u + Q_w)(p_w) = Q_u(p_w) + Q_w(p_w); the second term only changes when w's quadric grows.
    double geometric = weight > 0.0 ? std::max(eval(qu, t.p) + t.selfCost, 0.0) / weight : 0.0;
    if (normalWeight2 <= 0.0) return geometric;
    // Mean squared difference between the original normals merged into u and w and the normal w
    // carries (|m - n|² ≈ angle² for small angles), less the hard edges' own spread, as a distance:
    // weight * the input's edge length * angle.
    auto [dev, area] = normalDeviation(u, w);
    if (area <= 0.0) return geometric;
    return geometric + normalWeight2 * std::clamp(dev / area, 0.0, kMaxNormalDeviation2);
  }

  // cost(u, w, orderWeight2_) as a fraction num / den (den > 0), so that choosing among the
  // candidates of a vertex divides once, for the winner (the division was most of a candidate's
  // latency).
  using Fraction = SimplifyScratch::Fraction;
  Fraction orderCost(uint32_t u, uint32_t w) const {
    const Quadric& qu = s_.q[u];
    const SimplifyScratch::Target& t = s_.onto[w];
    double weight = qu.w + t.weight;
    double geometric = weight > 0.0 ? std::max(eval(qu, t.p) + t.selfCost, 0.0) : 0.0;
    if (!(weight > 0.0)) weight = 1.0;
    if (orderWeight2_ <= 0.0) return {geometric, weight};
    auto [dev, area] = normalDeviation(u, w);
    if (area <= 0.0) return {geometric, weight};
    // geometric / weight + k · clamp(dev / area) over the common denominator weight · area.
    dev = std::clamp(dev, 0.0, kMaxNormalDeviation2 * area);
    return {geometric * area + orderWeight2_ * dev * weight, weight * area};
  }
  // orderCost(u, w) of n candidates into out, two at a time with SSE2 (four with AVX where the CPU
  // has it): each lane does orderCost's operations in the same order (no fused multiply-add), so
  // the costs are bit-identical, and the branches become masks. Most of the simplifier's cost
  // evaluations are these.
  void orderCosts(uint32_t u, const uint32_t* cands, uint32_t n, Fraction* out) const {
#if defined(__x86_64__) && defined(__GNUC__)
    if (n >= 4 && hasAvx()) return orderCostsAvx(u, cands, n, out);
#endif
    uint32_t i = 0;
#if defined(__SSE2__)
    const Quadric& q = s_.q[u];
    const SimplifyScratch::Target* onto = s_.onto.data();
    const __m128d a00 = _mm_set1_pd(q.a00), a01 = _mm_set1_pd(q.a01), a02 = _mm_set1_pd(q.a02);
    const __m128d a11 = _mm_set1_pd(q.a11), a12 = _mm_set1_pd(q.a12), a22 = _mm_set1_pd(q.a22);
    const __m128d b0 = _mm_set1_pd(q.b0), b1 = _mm_set1_pd(q.b1), b2 = _mm_set1_pd(q.b2);
    const __m128d c = _mm_set1_pd(q.c), qw = _mm_set1_pd(q.w), zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0);
    const bool normals = orderWeight2_ > 0.0;
    const NormalQuadric nq = normals ? s_.nq[u] : NormalQuadric{};
    const glm::vec3* normal = normals ? s_.normal.data() : nullptr;
    const __m128d na = _mm_set1_pd(nq.a), nbx = _mm_set1_pd(nq.bx), nby = _mm_set1_pd(nq.by);
    const __m128d nbz = _mm_set1_pd(nq.bz), nc = _mm_set1_pd(nq.c), spread = _mm_set1_pd(nq.spread);
    const __m128d maxDev = _mm_set1_pd(kMaxNormalDeviation2), orderWeight2 = _mm_set1_pd(orderWeight2_);
    auto add = [](__m128d x, __m128d y) { return _mm_add_pd(x, y); };
    auto mul = [](__m128d x, __m128d y) { return _mm_mul_pd(x, y); };
    auto select = [](__m128d mask, __m128d yes, __m128d no) {
      return _mm_or_pd(_mm_and_pd(mask, yes), _mm_andnot_pd(mask, no));
    };
    for (; i + 2 <= n; i += 2) {
      const SimplifyScratch::Target &t0 = onto[cands[i]], &t1 = onto[cands[i + 1]];
      __m128d px = _mm_set_pd(t1.p.x, t0.p.x), py = _mm_set_pd(t1.p.y, t0.p.y), pz = _mm_set_pd(t1.p.z, t0.p.z);
      // geometric = weight > 0 ? max(Q_u(p_w) + Q_w(p_w), 0) : 0, then weight = 1 if not > 0.
      __m128d rx = add(add(add(mul(a00, px), mul(a01, py)), mul(a02, pz)), b0);
      __m128d ry = add(add(add(mul(a01, px), mul(a11, py)), mul(a12, pz)), b1);
      __m128d rz = add(add(add(mul(a02, px), mul(a12, py)), mul(a22, pz)), b2);
      __m128d e = add(add(add(mul(rx, px), mul(ry, py)), mul(rz, pz)), c);
      __m128d geometric = _mm_max_pd(zero, add(e, _mm_set_pd(t1.selfCost, t0.selfCost)));
      __m128d weight = add(qw, _mm_set_pd(t1.weight, t0.weight));
      __m128d positive = _mm_cmpgt_pd(weight, zero);
      geometric = _mm_and_pd(positive, geometric);
      weight = select(positive, weight, one);
      __m128d num = geometric, den = weight;
      if (normals) {
        // dev = selfDev_w + Σ a|m_w - n|² of u's corners - u's spread; area = a_u + a_w.
        glm::vec3 m0 = normal[cands[i]], m1 = normal[cands[i + 1]];
        __m128d mx = _mm_set_pd(m1.x, m0.x), my = _mm_set_pd(m1.y, m0.y), mz = _mm_set_pd(m1.z, m0.z);
        __m128d mm = add(add(mul(mx, mx), mul(my, my)), mul(mz, mz));
        __m128d mb = add(add(mul(mx, nbx), mul(my, nby)), mul(mz, nbz));
        __m128d dev = add(_mm_sub_pd(mul(na, mm), add(mb, mb)), nc);
        dev = _mm_sub_pd(add(_mm_set_pd(t1.selfDev, t0.selfDev), dev), spread);
        __m128d area = add(na, _mm_set_pd(t1.area, t0.area));
        dev = _mm_min_pd(mul(maxDev, area), _mm_max_pd(zero, dev)); // clamp(dev, 0, max · area)
        __m128d none = _mm_cmple_pd(area, zero);
        num = select(none, geometric, add(mul(geometric, area), mul(mul(orderWeight2, dev), weight)));
        den = select(none, weight, mul(weight, area));
      }
      _mm_storeu_pd(&out[i].num, _mm_unpacklo_pd(num, den));
      _mm_storeu_pd(&out[i + 1].num, _mm_unpackhi_pd(num, den));
    }
#endif
    for (; i < n; ++i) out[i] = orderCost(u, cands[i]);
  }

#if defined(__x86_64__) && defined(__GNUC__)
  static bool hasAvx() {
    static const bool avx = [] {
      __builtin_cpu_init();
      return __builtin_cpu_supports("avx");
    }();
    return avx;
  }

  // orderCosts four at a time (n >= 4; the last block ends at n, recomputing a few costs): the
  // SSE2 loop's operations, lane by lane, so the same bits. The candidates' records are loaded
  // whole and transposed.
  __attribute__((target("avx"))) void orderCostsAvx(uint32_t u, const uint32_t* cands, uint32_t n,
                                                    Fraction* out) const {
    const Quadric& q = s_.q[u];
    const SimplifyScratch::Target* onto = s_.onto.data();
    const __m256d a00 = _mm256_set1_pd(q.a00), a01 = _mm256_set1_pd(q.a01), a02 = _mm256_set1_pd(q.a02);
    const __m256d a11 = _mm256_set1_pd(q.a11), a12 = _mm256_set1_pd(q.a12), a22 = _mm256_set1_pd(q.a22);
    const __m256d b0 = _mm256_set1_pd(q.b0), b1 = _mm256_set1_pd(q.b1), b2 = _mm256_set1_pd(q.b2);
    const __m256d c = _mm256_set1_pd(q.c), qw = _mm256_set1_pd(q.w), zero = _mm256_setzero_pd();
    const __m256d one = _mm256_set1_pd(1.0);
    const bool normals = orderWeight2_ > 0.0;
    const NormalQuadric nq = normals ? s_.nq[u] : NormalQuadric{};
    const glm::vec3* normal = normals ? s_.normal.data() : nullptr;
    const __m256d na = _mm256_set1_pd(nq.a), nbx = _mm256_set1_pd(nq.bx), nby = _mm256_set1_pd(nq.by);
    const __m256d nbz = _mm256_set1_pd(nq.bz), nc = _mm256_set1_pd(nq.c), spread = _mm256_set1_pd(nq.spread);
    const __m256d maxDev = _mm256_set1_pd(kMaxNormalDeviation2), orderWeight2 = _mm256_set1_pd(orderWeight2_);
    for (uint32_t i = 0; i < n; i += 4) {
      uint32_t at = std::min(i, n - 4), w[4] = {cands[at], cands[at + 1], cands[at + 2], cands[at + 3]};
      const SimplifyScratch::Target *t0 = &onto[w[0]], *t1 = &onto[w[1]], *t2 = &onto[w[2]], *t3 = &onto[w[3]];
      // Records (p.x, p.y, p.z, selfCost | weight, area, selfDev, -) transposed into lanes.
      __m256d l0 = _mm256_load_pd(&t0->p.x), l1 = _mm256_load_pd(&t1->p.x);
      __m256d l2 = _mm256_load_pd(&t2->p.x), l3 = _mm256_load_pd(&t3->p.x);
      __m256d lo01 = _mm256_unpacklo_pd(l0, l1), hi01 = _mm256_unpackhi_pd(l0, l1);
      __m256d lo23 = _mm256_unpacklo_pd(l2, l3), hi23 = _mm256_unpackhi_pd(l2, l3);
      __m256d px = _mm256_permute2f128_pd(lo01, lo23, 0x20), pz = _mm256_permute2f128_pd(lo01, lo23, 0x31);
      __m256d py = _mm256_permute2f128_pd(hi01, hi23, 0x20), selfCost = _mm256_permute2f128_pd(hi01, hi23, 0x31);
      __m256d u0 = _mm256_load_pd(&t0->weight), u1 = _mm256_load_pd(&t1->weight);
      __m256d u2 = _mm256_load_pd(&t2->weight), u3 = _mm256_load_pd(&t3->weight);
      __m256d ulo01 = _mm256_unpacklo_pd(u0, u1), uhi01 = _mm256_unpackhi_pd(u0, u1);
      __m256d ulo23 = _mm256_unpacklo_pd(u2, u3), uhi23 = _mm256_unpackhi_pd(u2, u3);
      __m256d tw = _mm256_permute2f128_pd(ulo01, ulo23, 0x20), selfDev = _mm256_permute2f128_pd(ulo01, ulo23, 0x31);
      __m256d tarea = _mm256_permute2f128_pd(uhi01, uhi23, 0x20);
      // geometric = weight > 0 ? max(Q_u(p_w) + Q_w(p_w), 0) : 0, then weight = 1 if not > 0.
      __m256d rx = avxAdd(avxAdd(avxAdd(avxMul(a00, px), avxMul(a01, py)), avxMul(a02, pz)), b0);
      __m256d ry = avxAdd(avxAdd(avxAdd(avxMul(a01, px), avxMul(a11, py)), avxMul(a12, pz)), b1);
      __m256d rz = avxAdd(avxAdd(avxAdd(avxMul(a02, px), avxMul(a12, py)), avxMul(a22, pz)), b2);
      __m256d e = avxAdd(avxAdd(avxAdd(avxMul(rx, px), avxMul(ry, py)), avxMul(rz, pz)), c);
      __m256d geometric = _mm256_max_pd(zero, avxAdd(e, selfCost));
      __m256d weight = avxAdd(qw, tw);
      __m256d positive = _mm256_cmp_pd(weight, zero, _CMP_GT_OQ);
      geometric = _mm256_and_pd(positive, geometric);
      weight = avxSelect(positive, weight, one);
      __m256d num = geometric, den = weight;
      if (normals) {
        // Each normal loaded as four floats (the array has one spare entry), transposed.
        __m128 m0 = _mm_loadu_ps(&normal[w[0]].x), m1 = _mm_loadu_ps(&normal[w[1]].x);
        __m128 m2 = _mm_loadu_ps(&normal[w[2]].x), m3 = _mm_loadu_ps(&normal[w[3]].x);
        _MM_TRANSPOSE4_PS(m0, m1, m2, m3);
        __m256d mx = _mm256_cvtps_pd(m0), my = _mm256_cvtps_pd(m1), mz = _mm256_cvtps_pd(m2);
        __m256d mm = avxAdd(avxAdd(avxMul(mx, mx), avxMul(my, my)), avxMul(mz, mz));
        __m256d mb = avxAdd(avxAdd(avxMul(mx, nbx), avxMul(my, nby)), avxMul(mz, nbz));
        __m256d dev = avxAdd(_mm256_sub_pd(avxMul(na, mm), avxAdd(mb, mb)), nc);
        dev = _mm256_sub_pd(avxAdd(selfDev, dev), spread);
        __m256d area = avxAdd(na, tarea);
        dev = _mm256_min_pd(avxMul(maxDev, area), _mm256_max_pd(zero, dev)); // clamp(dev, 0, max · area)
        __m256d none = _mm256_cmp_pd(area, zero, _CMP_LE_OQ);
        num = avxSelect(none, geometric, avxAdd(avxMul(geometric, area), avxMul(avxMul(orderWeight2, dev), weight)));
        den = avxSelect(none, weight, avxMul(weight, area));
      }
      // (num, den) pairs in candidate order.
      __m256d lo = _mm256_unpacklo_pd(num, den), hi = _mm256_unpackhi_pd(num, den);
      _mm256_storeu_pd(&out[at].num, _mm256_permute2f128_pd(lo, hi, 0x20));
      _mm256_storeu_pd(&out[at + 2].num, _mm256_permute2f128_pd(lo, hi, 0x31));
    }
  }
#endif

  // The cheapest of the offered candidates (ties to the lower vertex id).
  struct Cheapest {
    Fraction best{std::numeric_limits<double>::max(), 1.0};
    uint32_t w = kNil;
    void offer(Fraction c, uint32_t x) {
      double l = c.num * best.den, r = best.num * c.den;
      if (l < r || (l == r && x < w)) best = c, w = x;
    }
    float cost() const { return float(best.num / best.den); }
  };

  // Indexed 4-ary min-heap over (cost, vertex): half the depth of a binary heap, one entry per
  // vertex (no stale entries), updated in place.
  void heapSet(uint32_t i, HeapItem item) {
    heap_[i] = item;
    s_.heapPos[item.v] = i;
  }
  void siftUp(uint32_t i) {
    HeapItem item = heap_[i];
    while (i > 0) {
      uint32_t parent = (i - 1) / 4;
      if (!(item.cost < heap_[parent].cost)) break;
      heapSet(i, heap_[parent]);
      i = parent;
    }
    heapSet(i, item);
  }
  void siftDown(uint32_t i) {
    HeapItem item = heap_[i];
    uint32_t n = heapSize_;
    for (;;) {
      uint32_t first = i * 4 + 1;
      if (first >= n) break;
      uint32_t best = first;
      if (first + 3 < n) {
        // Four children: a branch-free tournament (same pick as the scan: the first lowest).
        const HeapItem* h = &heap_[first];
        uint32_t a = h[1].cost < h[0].cost ? 1 : 0, b = h[3].cost < h[2].cost ? 3 : 2;
        best = first + (h[b].cost < h[a].cost ? b : a);
      } else {
        for (uint32_t c = first + 1; c < n; ++c)
          if (heap_[c].cost < heap_[best].cost) best = c;
      }
      if (!(heap_[best].cost < item.cost)) break;
      heapSet(i, heap_[best]);
      i = best;
    }
    heapSet(i, item);
  }
  void heapUpdate(uint32_t v, float c) {
    uint32_t i = s_.heapPos[v];
    if (i == kNil) {
      heap_[heapSize_] = {c, v};
      s_.heapPos[v] = heapSize_;
      siftUp(heapSize_++);
      return;
    }
    float old = heap_[i].cost;
    heap_[i].cost = c;
    if (c < old)
      siftUp(i);
    else
      siftDown(i);
  }
  void heapRemove(uint32_t v) {
    uint32_t i = s_.heapPos[v];
    if (i == kNil) return;
    s_.heapPos[v] = kNil;
    HeapItem last = heap_[--heapSize_];
    if (i == heapSize_) return;
    float old = heap_[i].cost;
    heapSet(i, last);
    if (last.cost < old)
      siftUp(i);
    else
      siftDown(i);
  }

  // v's cheapest collapse: sets target/time and returns its order cost, or -1 when v cannot
  // move. Optimistic: the cheapest candidate is taken untested and its legality is tested when it
  // comes up, so vertices that change again before then never pay for the test; otherwise the
  // cheapest legal candidate.
  float evaluate(uint32_t v, bool optimistic) {
    s_.dirty[v] = 0;
    if (!hasCorners(v) || m_.locked[v]) return -1.0f;
    if (savedRings_) return evaluateSaved(v);
    gatherRingU(v);
    Ring r = ringU();
    uint32_t n = 0;
    const uint32_t* cands = candidates(
        v, r.begin(), r.size, [&](uint32_t i) { return r.count(r.list[i]); }, n);
    if (optimistic) return queueCheapest(v, cands, n);
    s_.scored.clear();
    for (uint32_t i = 0; i < n; ++i)
      if (uint32_t w = cands[i]; w != knownIllegal_) s_.scored.push_back({cost(v, w, orderWeight2_), w});
    std::sort(s_.scored.begin(), s_.scored.end());
    for (auto [c, w] : s_.scored)
      if (legal(v, w)) {
        s_.target[v] = w, s_.time[v] = clock_;
        return float(c);
      }
    return -1.0f;
  }

  // The first, optimistic evaluation straight from the rings initQuadrics saved (the same
  // candidates in the same order as evaluate(), without copying them into a stamped ring).
  float evaluateSaved(uint32_t v) {
    const uint32_t *nbr = &s_.ringNbr[s_.ringStart[v]], *count = &s_.ringCnt[s_.ringStart[v]];
    uint32_t size = s_.ringStart[v + 1] - s_.ringStart[v], n = 0;
    const uint32_t* cands = candidates(
        v, nbr, size, [&](uint32_t i) { return count[i]; }, n);
    return queueCheapest(v, cands, n);
  }

  // v's collapse candidates in ring order (n of them: nbr itself when every neighbour is one, the
  // common case, else copied into s_.cands) among its distinct neighbours nbr[0..size), whose
  // edges to v have count(i) triangles: none when v must stay (a non-manifold edge, or several
  // open borders meet at v), only the neighbours across a border edge when v is on an open border
  // (it slides along it, so the border keeps its shape), else all; locked ones that cannot pass
  // legal() go (chordFree).
  template <class Count>
  const uint32_t* candidates(uint32_t v, const uint32_t* nbr, uint32_t size, Count&& count, uint32_t& n) {
    uint32_t borderEdges = 0, lockedAround = 0, nonManifold = 0;
    for (uint32_t i = 0; i < size; ++i) {
      uint32_t c = count(i);
      nonManifold |= c > 2;
      borderEdges += c == 1;
      lockedAround += m_.locked[nbr[i]];
    }
    n = 0;
    if (nonManifold || (borderEdges != 0 && borderEdges != 2)) return nbr;
    if (borderEdges == 0 && lockedAround == 0) {
      n = size;
      return nbr;
    }
    for (uint32_t i = 0; i < size; ++i)
      if ((borderEdges == 0 || count(i) == 1) && chordFree(v, nbr[i], lockedAround)) s_.cands[n++] = nbr[i];
    return s_.cands.data();
  }

  // Queues v's cheapest of the n candidates, untested (optimistic); -1 when n is 0.
  // All costs first, then the choice: the cost evaluations are independent of each other and
  // overlap, where choosing while evaluating chained each one to the previous comparison.
  float queueCheapest(uint32_t v, const uint32_t* cands, uint32_t n) {
    Fraction* costs = s_.candCost.data();
    orderCosts(v, cands, n, costs);
    Cheapest best;
    for (uint32_t i = 0; i < n; ++i) best.offer(costs[i], cands[i]);
    if (best.w == kNil) return -1.0f;
    s_.target[v] = best.w, s_.time[v] = kUnchecked;
    return best.cost();
  }

  // A necessary condition of legal(u, w), from u's triangles alone: when w is locked, every other
  // locked neighbour x of u must be a wing of the edge (a third corner of a triangle on u-w).
  // Otherwise x is either no neighbour of w (the collapse makes a new locked chord) or a common
  // neighbour that is no wing (the link condition fails). Most failed legality tests were such
  // chords next to the group border; filtering them while choosing the candidate saves gathering
  // w's ring to find out. lockedAround = locked neighbours of u.
  bool chordFree(uint32_t u, uint32_t w, uint32_t lockedAround) {
    if (!m_.locked[w]) return true;
    uint32_t others = lockedAround - 1;
    if (others == 0) return true;
    if (others > 2) return false;
    uint32_t lockedWings = 0;
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      const uint32_t* c = &m_.corners[t * 3];
      uint32_t a = c[kNextCorner[k]], b = c[kPrevCorner[k]];
      if (a == w) lockedWings += m_.locked[b];
      if (b == w) lockedWings += m_.locked[a];
    });
    return lockedWings >= others;
  }

  // Re-evaluates v and moves its entry (or drops it when v cannot move).
  void requeue(uint32_t v, bool optimistic) {
    float c = evaluate(v, optimistic);
    if (c < 0.0f)
      heapRemove(v);
    else
      heapUpdate(v, c);
  }

  // v's neighbourhood changed: re-evaluate it when its (stale) entry comes up; a vertex without
  // an entry gets one at the current cost level so it is looked at again soon.
  void markDirty(uint32_t v, float c) {
    if (m_.locked[v] || !hasCorners(v)) return;
    s_.dirty[v] = 1;
    if (s_.heapPos[v] == kNil) heapUpdate(v, c);
  }

  // ringsKnown: legal(u, w) just passed, so ringU and ringW hold u's and w's rings.
  void collapse(uint32_t u, uint32_t w, float queuedCost, bool ringsKnown) {
    // Attribute wedges: a corner of u takes the attribute w has in a dying triangle on the same
    // side of any attribute seam (same attribute at u), so UV charts stay consistent.
    std::vector<std::pair<uint32_t, uint32_t>>& pairs = s_.pairs;
    std::vector<uint32_t>& kept = s_.kept; // u's corners in surviving triangles, in list order
    pairs.clear();
    kept.clear();
    forTriangles(u, [&](uint32_t t, uint32_t k) {
      uint32_t* v = &m_.corners[t * 3];
      if (v[0] != w && v[1] != w && v[2] != w) {
        kept.push_back(t * 3 + k);
        return;
      }
      for (uint32_t j = 0; j < 3; ++j)
        if (v[j] == w) pairs.push_back({m_.attributes[t * 3 + k], m_.attributes[t * 3 + j]});
      s_.alive[t] = 0;
      --live_;
    });
    for (uint32_t c : kept) {
      m_.corners[c] = w;
      uint32_t& a = m_.attributes[c];
      uint32_t mapped = pairs.empty() ? a : pairs[0].second;
      for (auto [from, to] : pairs)
        if (from == a) mapped = to;
      a = mapped;
    }
    add(s_.q[w], s_.q[u]);
    SimplifyScratch::Target& t = s_.onto[w];
    t.selfCost = eval(s_.q[w], s_.p[w]), t.weight = s_.q[w].w;
    if (normalWeight2_ > 0.0) {
      add(s_.nq[w], s_.nq[u]);
      t.selfDev = deviation(s_.nq[w], glm::dvec3(s_.normal[w])) - s_.nq[w].spread, t.area = s_.nq[w].a;
    }
    // w's corner list becomes its live corners plus u's: dropping dead ones keeps lists short.
    uint32_t* list = s_.lists.data() + s_.listStart[w];
    uint32_t live = 0;
    for (uint32_t i = 0, size = s_.listSize[w]; i < size; ++i) {
      uint32_t c = list[i];
      list[live] = c;
      live += s_.alive[c / 3];
    }
    uint32_t size = live + uint32_t(kept.size());
    if (size > s_.listCap[w]) {
      // Out of room: the list moves to the end (u's room is not reused; groups are small).
      uint32_t start = uint32_t(s_.lists.size());
      s_.lists.resize(start + size + kListSlack);
      std::copy_n(s_.lists.data() + s_.listStart[w], live, s_.lists.data() + start);
      s_.listStart[w] = start, s_.listCap[w] = size + kListSlack;
      list = s_.lists.data() + start;
    }
    std::copy(kept.begin(), kept.end(), list + live);
    s_.listSize[w] = size;
    s_.listSize[u] = 0;
    ++clock_;
    s_.changed[w] = clock_;
    markDirty(w, queuedCost);
    auto touch = [&](uint32_t x) {
      s_.changed[x] = clock_;
      markDirty(x, queuedCost);
    };
    if (ringsKnown) {
      // w's new neighbours are among u's and w's old ones (a few twice: harmless), so no walk.
      for (uint32_t x : ringW())
        if (x != u) touch(x);
      for (uint32_t x : ringU())
        if (x != w) touch(x);
      return;
    }
    Ring touched = ringW();
    gatherRing(w, touched);
    for (uint32_t x : touched) touch(x);
  }

  void compact() {
    size_t out = 0;
    for (size_t t = 0; t < s_.alive.size(); ++t) {
      if (!s_.alive[t]) continue;
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
  SimplifyScratch& s_;
  glm::dvec3 center_;
  double normalWeight2_ = 0.0, orderWeight2_ = 0.0;
  uint32_t ringUOf_ = kNil, ringUClock_ = 0; // whose ring ringU holds, gathered at which clock
  uint32_t clock_ = 0, genU_ = 0, genW_ = 0, sizeU_ = 0, sizeW_ = 0, endsU_ = 0, endsW_ = 0;
  uint32_t knownIllegal_ = kNil; // a target legal() just refused for the vertex being re-evaluated
  bool savedRings_ = false;      // evaluate() reads the rings saved by initQuadrics (first evaluation)
  size_t live_ = 0;
  HeapItem* heap_ = nullptr; // into s_.heap, aligned as described in the constructor
  uint32_t heapSize_ = 0;
  double maxCost_ = 0.0;
};

} // namespace

float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles, SimplifyScratch& scratch) {
  if (mesh.corners.size() / 3 <= targetTriangles) return 0.0f;
  Simplifier s(mesh, scratch);
  return s.run(targetTriangles);
}

float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles) {
  SimplifyScratch scratch;
  return simplifyLocked(mesh, targetTriangles, scratch);
}

} // namespace mirage::lod::detail
