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
  std::vector<double> selfDev;   // Σ a·|m_v − n|² − spread of v's own normal quadric, kept up to date
  std::vector<double> selfCost;  // Q_v(p_v): the target's share of a collapse cost, kept up to date
  std::vector<uint32_t> ringStart, ringNbr, ringCnt; // rings at setup, reused by the first evaluation
  std::vector<uint32_t> head, next, version, changed, stampU, stampW, countU, countW, ringU, ringW;
  std::vector<uint32_t> ringEnds; // gatherRing's edge ends of one vertex
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

} // namespace mirage::lod::detail
