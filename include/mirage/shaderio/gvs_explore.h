// GVS++ exploration rays, shared by C++ and GLSL: the structs of the device-made adaptive border
// (ABS) and reverse (RS) rays (vulkan_backend.cpp, shaders/vis_trace_common.glsl) and the formulas
// both the host sampler (src/visibility/gvs.cpp) and the shaders make those rays with, written once.
// docs/visibility.md, "Rays made on the device".
#ifndef MIRAGE_SHADERIO_GVS_EXPLORE_H
#define MIRAGE_SHADERIO_GVS_EXPLORE_H

#include "mirage/shaderio/rays.h"

#ifdef __cplusplus
namespace mirage::shaderio {
using glm::abs;
using glm::cross;
using glm::dot;
using glm::length;
using glm::max;
using glm::mix;
using glm::normalize;
#define MIRAGE_GVS_FN inline
#else
#define MIRAGE_GVS_FN
#endif

// Ray sources of the exploration phases (RtTracePush::mode; push.cell points at an RtExploreSource).
// MODE_BORDER: ray i is point i % raysPerItem of the enlarged border polygon of item i / raysPerItem,
// shot from the item's origin; where it meets a discontinuity an RtDiscontinuity is appended.
// MODE_REVERSE: ray i is origin i % raysPerItem of seed i / raysPerItem (cell edges, then Halton
// points on the cell surface), aimed at the seed's target. Rays the host sampler would drop
// (degenerate border, zero direction, inside the occluder's shadow, not traceable) are skipped:
// not traced, not counted (RtCounters::traced), no claim.
#define MIRAGE_RT_MODE_BORDER 4u
#define MIRAGE_RT_MODE_REVERSE 5u
// Edges of a box cell (a rect has 4).
#define MIRAGE_RT_MAX_CELL_EDGES 12

// A discovery to border-sample: the triangle and the origin of the ray that found it.
struct RtBorderItem {
  vec3 origin;
  uint triangle;
};

// A discontinuity to reverse-sample: the point the ABS ray aimed at and what it hit nearer (or none).
struct RtReverseItem {
  vec3 target;
  uint occluder;
};

// Written by MODE_BORDER for every traced ray that missed or hit nearer than its target by more than
// rsDeltaRelative of the target's distance; `ray` is its launch index (the host sorts by it).
struct RtDiscontinuity {
  vec3 target;
  uint occluder;
  uint ray;
};

struct RtCellEdge {
  vec3 a;
  float len; // |b - a|, as the host measures it
  vec3 b;
  float pad0;
};

struct RtExploreSource {
  RtCellSource cell;        // before, firstRay (claims) and the faces (RS area points); firstIndex unused
  uint64_t items;           // RtBorderItem[] or RtReverseItem[]
  uint64_t discontinuities; // MODE_BORDER: RtDiscontinuity[count], appended (RtCounters::discontinuities)
  uint64_t triangles;       // vec3[3] per global triangle ID, world space
  uint64_t rays;            // optional RtRay[count]: the generated rays (tfar < 0: skipped), for tests
  uint64_t firstSeed;       // MODE_REVERSE: sequence index of item 0 (edge shift, Halton points)
  uint raysPerItem;
  uint absEdgeSamples;
  float absDeltaTriangle; // border enlargement: this fraction of the longest edge ...
  float absDeltaAbsolute; // ... plus this (absDeltaScene times the scene diagonal)
  float rsDeltaRelative;
  uint rsEdgeSamples;
  uint rsAreaSamples;
  uint edgeCount;
  float edgeLength; // sum of the edges' lengths
  float rsOffset0;  // Cranley-Patterson offsets of the RS Halton points (bases 2, 3, 5)
  float rsOffset1;
  float rsOffset2;
  RtCellEdge edges[MIRAGE_RT_MAX_CELL_EDGES];
};

// Outward in-plane normal of the edge p -> q of the triangle (p, q, r) with normal n.
MIRAGE_GVS_FN vec3 absEdgeNormal(vec3 p, vec3 q, vec3 r, vec3 n) {
  vec3 e = normalize(cross(q - p, n));
  return dot(e, r - p) > 0.0f ? -e : e;
}

// Δ_ABS of a triangle: `relative` of its longest edge plus `absolute`.
MIRAGE_GVS_FN float absDelta(vec3 v0, vec3 v1, vec3 v2, float relative, float absolute) {
  float longest = max(max(length(v1 - v0), length(v2 - v1)), length(v0 - v2));
  return relative * longest + absolute;
}

// Point k (0 .. 9 + 3 * edgeSamples - 1) of the triangle's 9-vertex border polygon enlarged by
// `delta` (en0..en2: the outward normals of edges 0-1, 1-2, 2-0): per corner i, the corner moved
// along the previous edge's normal, along the bisector, along the next edge's normal, then
// `edgeSamples` points inside the long edge parallel to edge i -> i+1.
MIRAGE_GVS_FN vec3 absPoint(vec3 v0, vec3 v1, vec3 v2, vec3 en0, vec3 en1, vec3 en2, float delta, uint k,
                            uint edgeSamples) {
  uint i = k / (3u + edgeSamples), r = k % (3u + edgeSamples);
  vec3 v = i == 0u ? v0 : (i == 1u ? v1 : v2);
  vec3 w = i == 0u ? v1 : (i == 1u ? v2 : v0);
  vec3 prev = i == 0u ? en2 : (i == 1u ? en0 : en1);
  vec3 next = i == 0u ? en0 : (i == 1u ? en1 : en2);
  if (r == 0u) return v + delta * prev;
  if (r == 1u) return v + delta * normalize(prev + next);
  vec3 a = v + delta * next;
  if (r == 2u) return a;
  vec3 b = w + delta * next;
  return mix(a, b, float(r - 2u) / float(edgeSamples + 1u));
}

// Möller-Trumbore: does the segment o -> o + d (t in (0, 1)) cross the triangle? (RS: an origin
// in the occluder's shadow on the cell.)
MIRAGE_GVS_FN bool segmentHitsTriangle(vec3 o, vec3 d, vec3 a, vec3 b, vec3 c) {
  vec3 e1 = b - a, e2 = c - a;
  vec3 p = cross(d, e2);
  float det = dot(e1, p);
  if (abs(det) < 1e-20f) return false;
  float inv = 1.0f / det;
  vec3 s = o - a;
  float u = dot(s, p) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  vec3 q = cross(s, e1);
  float v = dot(d, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  float t = dot(e2, q) * inv;
  return t > 1e-4f && t < 1.0f - 1e-4f;
}

#ifndef __cplusplus
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer RtExploreSourceRef { RtExploreSource s; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtBorderItemRef { RtBorderItem v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtReverseItemRef { RtReverseItem v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtDiscontinuityRef { RtDiscontinuity v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtVec3Ref { vec3 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtRayRef { RtRay v[]; };
#endif

#ifdef __cplusplus
static_assert(sizeof(RtBorderItem) == 16, "RtBorderItem layout");
static_assert(sizeof(RtReverseItem) == 16, "RtReverseItem layout");
static_assert(sizeof(RtDiscontinuity) == 20, "RtDiscontinuity layout");
static_assert(sizeof(RtCellEdge) == 32, "RtCellEdge layout");
static_assert(sizeof(RtExploreSource) == sizeof(RtCellSource) + 40 + 48 + 32 * MIRAGE_RT_MAX_CELL_EDGES,
              "RtExploreSource layout");
} // namespace mirage::shaderio
#endif

#endif
