#pragma once
// Quadric-error half-edge-collapse simplifier with explicit per-vertex locks, written for the DAG
// builder because meshoptimizer 0.18 can only lock *every* open-border vertex (which also freezes
// the mesh's own border) and scans its whole vertex buffer per call. See docs/lod.md.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace mirage::lod::detail {

struct SimplifyMesh {
  std::vector<glm::vec3> positions; // compact, welded: topology is decided on these
  std::vector<uint8_t> locked;      // per position: 1 = must not move (group border)
  std::vector<uint32_t> corners;    // position id per triangle corner, 3 per triangle
  std::vector<uint32_t> attributes; // carried attribute-vertex id per corner
  // Unit normal per attribute-vertex id (indexed by `attributes`), or null: no normal term.
  const glm::vec3* normals = nullptr;
  // Normal deviation counts as normalWeight * edge length * angle (radians) of distance in the
  // reported error (half of it in the collapse order), so the error covers shading changes as well
  // as geometric ones. 0 = geometric error only.
  float normalWeight = 0.0f;
  // The length that turns a normal angle into a distance (the input's RMS edge length, see
  // BuildConfig::normalWeight); > 0 when normalWeight is.
  float normalLength = 0.0f;
};

// Plane quadric, relative to the group centre: Σ w (n·p + d)², and Σ w; b holds 2 Σ w n d.
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0, w = 0;
};

inline Quadric planeQuadric(glm::dvec3 n, double d, double weight) {
  Quadric q;
  q.a00 = weight * n.x * n.x, q.a01 = weight * n.x * n.y, q.a02 = weight * n.x * n.z;
  q.a11 = weight * n.y * n.y, q.a12 = weight * n.y * n.z, q.a22 = weight * n.z * n.z;
  // b is stored doubled (exact: a factor of 2 commutes with rounding), saving eval three products.
  q.b0 = 2.0 * (weight * n.x * d), q.b1 = 2.0 * (weight * n.y * d), q.b2 = 2.0 * (weight * n.z * d);
  q.c = weight * d * d;
  q.w = weight;
  return q;
}

inline void add(Quadric& q, const Quadric& o) {
  q.a00 += o.a00, q.a01 += o.a01, q.a02 += o.a02, q.a11 += o.a11, q.a12 += o.a12, q.a22 += o.a22;
  q.b0 += o.b0, q.b1 += o.b1, q.b2 += o.b2, q.c += o.c, q.w += o.w;
}

// Sum of weighted squared plane distances at p.
inline double eval(const Quadric& q, glm::dvec3 p) {
  double rx = q.a00 * p.x + q.a01 * p.y + q.a02 * p.z + q.b0;
  double ry = q.a01 * p.x + q.a11 * p.y + q.a12 * p.z + q.b1;
  double rz = q.a02 * p.x + q.a12 * p.y + q.a22 * p.z + q.b2;
  return rx * p.x + ry * p.y + rz * p.z + q.c;
}

// Normal "quadric" of the original corners merged into a vertex: Σ a, Σ a·n, Σ a·n·n, so that
// Σ a |m - n|² for the normal m the vertex carries is a|m|² - 2 b·m + c. `spread` is that sum for
// each merged vertex at its own normal when the group was set up: the spread a hard edge (several
// normals at one position) has before any collapse, which the carried wedges keep, so it is not
// counted as a change.
struct NormalQuadric {
  double a = 0, bx = 0, by = 0, bz = 0, c = 0, spread = 0;
};

// Per-thread buffers of simplifyLocked, reused from call to call (no per-group allocations).
struct SimplifyScratch {
  std::vector<glm::dvec3> p;
  std::vector<Quadric> q;
  std::vector<NormalQuadric> nq;
  std::vector<glm::vec3> normal; // normal a vertex carries (area-weighted over its corners)
  // What costing a collapse onto v reads of v, in one cache line (a candidate's data was spread
  // over six arrays): copies of p, q.w and nq.a, and v's own share of the cost, kept up to date.
  struct alignas(64) Target {
    glm::dvec3 p;
    double selfCost = 0; // Q_v(p_v)
    double weight = 0;   // q[v].w
    double area = 0;     // nq[v].a
    double selfDev = 0;  // Σ a·|m_v − n|² − spread of v's own normal quadric
  };
  std::vector<Target> onto;
  std::vector<uint32_t> ringStart, ringNbr, ringCnt;    // rings at setup, reused by the first evaluation
  std::vector<double> triLen;                           // per triangle at setup: twice its area (<= 0: degenerate)
  std::vector<std::pair<uint32_t, uint32_t>> openEdges; // open edges (a < b) at setup, in ring order
  // Each vertex's corners (3 t + k), contiguous: lists[listStart[v] ..+ listSize[v]], room for
  // listCap[v]; a list that outgrows its room moves to the end of `lists`.
  std::vector<uint32_t> lists, listStart, listSize, listCap;
  std::vector<uint32_t> changed, ringU, ringW;
  // Per vertex, its gather stamp (high half) and edge use count (low half) in ringU / ringW: one
  // load answers "how many triangles on the edge to x".
  std::vector<uint64_t> markU, markW;
  // gatherRing's edge ends of a vertex (the two other corners of each live triangle, in list
  // order), one buffer per ring: legal() tests u's triangles from endsU without walking them again.
  std::vector<uint32_t> endsU, endsW;
  struct Fraction {
    double num, den; // a collapse cost num / den
  };
  std::vector<uint32_t> cands;    // one vertex's collapse candidates ...
  std::vector<Fraction> candCost; // ... and their costs
  std::vector<uint8_t> alive, dirty;
  std::vector<std::pair<double, uint32_t>> scored;
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  std::vector<uint32_t> kept;
  // One queued collapse per vertex (v -> target[v]) in an indexed 4-ary min-heap of (cost, v):
  // heapPos[v] is v's slot or ~0u. time[v] = collapse clock when the entry's legality was tested
  // (~0u: not tested yet).
  struct HeapItem {
    float cost;
    uint32_t v;
  };
  std::vector<HeapItem> heap;
  std::vector<uint32_t> heapPos, target, time;
};

// Collapses edges (the removed vertex moves onto a kept neighbour, so no new positions or
// attributes appear) in order of cost until at most targetTriangles remain or no legal collapse is
// left. Locked vertices never move; an unlocked open-border vertex only slides along its border;
// non-manifold vertices stay. Rewrites corners/attributes to the surviving triangles and returns
// the error: the square root of the largest cost collapsed, a distance in position units (the
// area-normalised plane quadric plus the weighted normal term, see SimplifyMesh::normalWeight).
float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles, SimplifyScratch& scratch);
float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles);

// Fallback for a group the collapses cannot bring below the stuck ratio (scan tunnels and complex
// vertices: simplifyLocked keeps topology): vertex clustering on uniform grids, from fine to
// coarse, until at most targetTriangles remain. Per grid, the movable vertices (not locked, not on
// the group's open border) connected inside one cell merge into the one with the least error of
// their summed quadric, cheapest merges first, each applied only when it keeps the DAG verifier's
// group rules on the edges it touches (the open edges stay, no edge gets more than two triangles
// unless it had as many, the area stays within 40 %). Degenerate triangles go and copies of one
// triangle cancel in pairs, so a closed tunnel leaves no hole. Rewrites corners/attributes (a
// moved corner takes an attribute vertex of its new position) and returns the error (2x the
// largest merged cell quadric distance: topology changes look worse than the plane distance
// says), or -1 with the mesh untouched when no merge was possible.
float simplifyClustered(SimplifyMesh& mesh, size_t targetTriangles);

} // namespace mirage::lod::detail
