// Structs shared by C++ and GLSL for the Vulkan ray backend (src/visibility/vulkan_backend.cpp,
// src/visibility/ray_bvh.cpp, shaders/vis_trace*): written once, compiled by both. GLSL reads them with scalar block
// layout through buffer device addresses; the static_asserts keep the C++ sizes equal to what shaders read.
#ifndef MIRAGE_SHADERIO_RAYS_H
#define MIRAGE_SHADERIO_RAYS_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using vec3 = glm::vec3;
using uint = uint32_t;
#endif

#define MIRAGE_RT_NO_HIT 0xffffffffu
// kHitNew, kHitMissing, kHitSeeThroughNew of ray_backend.h
#define MIRAGE_RT_HIT_NEW 1u
#define MIRAGE_RT_HIT_MISSING 2u
#define MIRAGE_RT_HIT_SEE_THROUGH_NEW 4u
// See-through hits a ray remembers in its payload (Embree keeps 64 per ray; ones behind the
// closest hit so far are dropped when the list is full, so 8 only overflow behind 8 panes).
#define MIRAGE_RT_MAX_CANDIDATES 8
// Ray sources: rays read from a buffer, or generated in the ray-generation shader (uniform
// origins in a box, uniform directions; nothing uploaded).
#define MIRAGE_RT_MODE_BUFFER 0u
#define MIRAGE_RT_MODE_GENERATED 1u
// GVS++ random rays of a view cell made in the ray-generation shader (RtCellSource): randomized
// Halton origins on the cell surface, uniform directions; only first discoveries come back.
#define MIRAGE_RT_MODE_CELL 2u
// Rays read from a buffer of 24-byte (origin, direction) pairs, the interval [0, inf): what every
// GVS++ ray is. A third fewer bytes than RtRay across PCIe, where host-made rays live.
#define MIRAGE_RT_MODE_COMPACT 3u
// Faces of a box cell (a rect has one).
#define MIRAGE_RT_MAX_CELL_FACES 6
// Rays per row of a launch: launches are 2D because one launch dimension is limited (65535 × 1024
// on common devices, less than the millions of rays a batch holds).
#define MIRAGE_RT_LAUNCH_WIDTH 32768u

// Same layout as vis::Ray and vis::Hit (static_asserts in vulkan_backend.cpp).
struct RtRay {
  vec3 origin;
  float tnear;
  vec3 dir;
  float tfar;
};

struct RtHit {
  uint triangle;
  float t;
  uint flags;
  uint seeThrough;
};

// Per TLAS instance (instanced scenes) or per BLAS geometry (flattened scenes): the first global
// triangle ID and whether the triangles are see-through.
struct RtSlot {
  uint firstTriangle;
  uint seeThrough;
};

struct RtCounters {
  uint newCount;        // IDs appended to newIds (first insertions into the record set)
  uint nextBatch;       // compute traversal, persistent threads: rays handed out so far
  uint discontinuities; // MODE_BORDER: RtDiscontinuity records appended (gvs_explore.h)
  uint traced;          // MODE_BORDER, MODE_REVERSE: rays not skipped
};

// One cell face: corner + u·edgeU + v·edgeV, picked when its cumulative area fraction exceeds the
// sample's face coordinate.
struct RtCellFace {
  vec3 corner;
  float cdf; // cumulative area fraction up to and including this face
  vec3 edgeU;
  float pad0;
  vec3 edgeV;
  float pad1;
};

// MODE_CELL: ray `i` of a launch is Halton point firstIndex + i + 1 (bases 2, 3, 5, 7, 11: face,
// u, v, two direction coordinates) shifted by `offset` (Cranley-Patterson), as in sampling.h. A
// ray whose closest or nearest see-through triangle is absent from `before` (the record set when
// the launch began) takes part in atomicMin(firstRay[triangle], i): the lowest-indexed ray wins
// whatever the scheduling, so the discoveries the host reads back are reproducible.
struct RtCellSource {
  uint64_t before;   // uint bit set, read-only during the launch
  uint64_t firstRay; // uint per triangle: lowest launch index that found it (~0u: none)
  uint64_t firstIndex;
  uint faceCount;
  float offset0;
  float offset1;
  float offset2;
  float offset3;
  float offset4;
  RtCellFace faces[MIRAGE_RT_MAX_CELL_FACES];
};

// Compute traversal (vis_trace.comp): a binary BVH in the Aila-Laine layout, both children's boxes
// in one 64-byte node so one fetch (four 16-byte loads) tests two boxes. A child reference is a
// node index, or MIRAGE_RT_BVH_LEAF | the first of the leaf's triangles, which run up to one
// flagged MIRAGE_RT_BVH_LAST. Node 0 is the root.
#define MIRAGE_RT_BVH_LEAF 0x80000000u
#define MIRAGE_RT_BVH_NONE 0x7fffffffu // stack sentinel: above every node index, not a leaf
#define MIRAGE_RT_BVH_LAST 1u          // RtBvhTriangle::flags: the leaf's last triangle
#define MIRAGE_RT_BVH_SEE_THROUGH 2u   // RtBvhTriangle::flags: a Blend or Mask material
#define MIRAGE_RT_BVH_STACK 64         // per-thread traversal stack (the builder's depth limit)
// Rays per workgroup of the compute traversal.
#define MIRAGE_RT_COMPUTE_GROUP 64u

struct RtBvhNode {
  vec3 lo0;
  float hi0x;
  float hi0y;
  float hi0z;
  float lo1x;
  float lo1y;
  float lo1z;
  float hi1x;
  float hi1y;
  float hi1z;
  uint child0;
  uint child1;
  uint pad0;
  uint pad1;
};

// The 4-wide variant (VulkanRayOptions::bvhWidth = 4, vis_trace_bvh4.comp): four children's boxes
// as six planes of four (one 16-byte load each, so the slab test runs on vec4s) and their
// references (MIRAGE_RT_BVH_NONE where a node has fewer than four children), 112 bytes.
struct RtBvh4Node {
  float loX[4];
  float hiX[4];
  float loY[4];
  float hiY[4];
  float loZ[4];
  float hiZ[4];
  uint child[4];
};

// The 8-wide compressed variant (VulkanRayOptions::bvhWidth = 8, vis_trace_bvh8.comp), after
// Ylitie, Karras & Laine 2017 ("Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
// BVHs"), 80 bytes (five 16-byte loads) for eight children. Child boxes are 8-bit offsets from the
// node's `origin` in steps of 2^e per axis (e + 127 in a byte, like a float exponent: the shader
// makes the step with one shift), rounded outwards, so a decoded box always contains the child's
// (padded) box. Slot s holds the child nearest first for rays of direction octant s (bit 0: x < 0,
// bit 1: y < 0, bit 2: z < 0). The inner children are stored consecutively from `childBase` in slot
// order (bit s of imask: slot s is an inner node), the leaves' triangles consecutively from
// `triangleBase`. A slot's meta byte: 0 empty; inner (1 << 5) | (24 + s); leaf (the count in unary:
// 1, 3 or 7) << 5 | the offset of its first triangle from triangleBase (0..23). The shader ORs
// `meta >> 5` shifted by the low five bits into a 32-bit hit mask: triangles in bits 0..23, inner
// children in bits 24..31, with the slot XORed by the ray's inverted octant so that the highest
// bit is the nearest child.
#define MIRAGE_RT_BVH8_LEAF_MAX 3u    // triangles per leaf (three unary bits)
#define MIRAGE_RT_BVH8_STACK 32       // node groups (uvec2) per thread; the builder's depth limit
#define MIRAGE_RT_BVH8_INNER_META 56u // (1 << 5) | 24: plus the slot
struct RtBvh8Node {
  vec3 origin;
  uint exponents; // e.x + 127 | (e.y + 127) << 8 | (e.z + 127) << 16 | imask << 24
  uint childBase;
  uint triangleBase;
  uint meta[2]; // slots 0-3, 4-7, one byte each
  uint loX[2];  // quantized lower x of slots 0-3 and 4-7, one byte each
  uint hiX[2];
  uint loY[2];
  uint hiY[2];
  uint loZ[2];
  uint hiZ[2];
};

// A leaf triangle: world-space corners and the global ID, three 16-byte loads.
struct RtBvhTriangle {
  vec3 v0;
  uint id;
  vec3 v1;
  uint flags; // MIRAGE_RT_BVH_LAST | MIRAGE_RT_BVH_SEE_THROUGH
  vec3 v2;
  uint pad0;
};

struct RtTracePush {
  uint64_t rays;     // RtRay[count] (MODE_BUFFER) or float[6 * count] (MODE_COMPACT)
  uint64_t hits;     // RtHit[count]; 0: not written
  uint64_t record;   // uint bit set of global IDs; 0: none
  uint64_t require;  // uint bit set; 0: none
  uint64_t newIds;   // uint[newCapacity]: IDs whose insertion into `record` was the first
  uint64_t counters; // RtCounters
  uint64_t slots;    // RtSlot[instances or geometries]
  vec3 boxMin;       // MODE_GENERATED: origins uniform in [boxMin, boxMax]
  uint count;        // rays in this launch
  vec3 boxMax;
  uint mode; // MIRAGE_RT_MODE_*
  uint newCapacity;
  uint seed;             // MODE_GENERATED: random stream
  uint onlyRequired;     // 1: triangles outside `require` do not exist (the PVS-only render)
  uint persistent;       // compute traversal: threads fetch rays from RtCounters::nextBatch
  uint64_t cell;         // MODE_CELL: RtCellSource
  uint64_t bvhNodes;     // compute traversal: RtBvhNode[], vec4-aligned
  uint64_t bvhTriangles; // compute traversal: RtBvhTriangle[]
};

// vis_first_rays.comp, after a claiming launch (MODE_CELL, MODE_BORDER, MODE_REVERSE): gathered[k] =
// firstRay[newIds[k]] for the launch's first insertions, so the host reads 4 bytes per new triangle
// instead of the whole per-triangle array.
#define MIRAGE_RT_GATHER_GROUP 64u
#define MIRAGE_RT_GATHER_GROUPS 256u // a grid-stride loop: the count is known on the device only
struct RtGatherPush {
  uint64_t newIds;   // uint[]: RtTracePush::newIds
  uint64_t counters; // RtCounters: newCount
  uint64_t firstRay; // uint per triangle
  uint64_t gathered; // uint[newCapacity]
  uint newCapacity;
  uint pad0;
};

#ifndef __cplusplus
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtSlotRef { RtSlot v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtCountersRef { RtCounters c; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RtU32Ref { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer RtCellSourceRef { RtCellSource s; };
// RtBvhNode and RtBvhTriangle read as 16-byte vectors: four per node, three per triangle;
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RtVec4Ref { vec4 v[]; };
// RtRay read as two 16-byte vectors, RtHit written as one, a compact ray as three 8-byte ones.
layout(buffer_reference, std430, buffer_reference_align = 8) buffer RtVec2Ref { vec2 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) buffer RtUVec4Ref { uvec4 v[]; };
#endif

#ifdef __cplusplus
static_assert(sizeof(RtRay) == 32, "RtRay layout");
static_assert(sizeof(RtHit) == 16, "RtHit layout");
static_assert(sizeof(RtSlot) == 8, "RtSlot layout");
static_assert(sizeof(RtCounters) == 16, "RtCounters layout");
static_assert(sizeof(RtCellFace) == 48, "RtCellFace layout");
static_assert(sizeof(RtCellSource) == 48 + 48 * MIRAGE_RT_MAX_CELL_FACES, "RtCellSource layout");
static_assert(sizeof(RtGatherPush) == 40, "RtGatherPush layout");
static_assert(sizeof(RtBvhNode) == 64, "RtBvhNode layout");
static_assert(sizeof(RtBvhTriangle) == 48, "RtBvhTriangle layout");
static_assert(sizeof(RtBvh4Node) == 112, "RtBvh4Node layout");
static_assert(sizeof(RtBvh8Node) == 80, "RtBvh8Node layout");
static_assert(sizeof(RtTracePush) == 128, "RtTracePush layout: 128 bytes, the smallest push constant limit");
} // namespace mirage::shaderio
#endif

#endif
