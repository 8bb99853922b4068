// Order-independent transparency shared by the forward and cluster-LOD renderers (docs/render.md,
// "Transparency"): per-pixel linked lists of blended fragments (Yang et al. 2010), written once for
// C++ and GLSL (shaders/oit_list.glsl holds the code on them).
#ifndef MIRAGE_SHADERIO_OIT_H
#define MIRAGE_SHADERIO_OIT_H

#ifdef __cplusplus
#include <cstdint>
namespace mirage::shaderio {
using uint = uint32_t;
#endif

// Fragments kept and sorted per pixel by a resolve (the nearest ones; farther ones past this are
// dropped and counted).
#define MIRAGE_OIT_MAX_LAYERS 16
// The forward renderer's exact mode (--oit sorted) keeps this many instead.
#define MIRAGE_OIT_SORTED_LAYERS 64

// Pool overflow and the per-pixel cap (oit_list.glsl, oitClaimFarthest): a fragment arriving once
// the pool is full, or once its pixel holds MIRAGE_OIT_MAX_LAYERS, walks at most this many nodes
// of its pixel's list (which the cap keeps at most MIRAGE_OIT_MAX_LAYERS long) for one farther than
// itself to replace, and walks again at most this many times when another fragment took that node
// first.
#define MIRAGE_OIT_REPLACE_STEPS 64
#define MIRAGE_OIT_REPLACE_TRIES 4

// One pixel's list (the heads buffer holds one per pixel, zeroed at the frame start). Only the
// first MIRAGE_OIT_MAX_LAYERS fragments of a pixel take nodes from the pool, so a few pixels under
// thousands of fragments cannot starve the rest of the screen; later ones replace the farthest
// listed (the resolve keeps the nearest MIRAGE_OIT_MAX_LAYERS anyway, so where no pixel passes the
// cap nothing changes). `floorBits` lets most of them go with one load instead of a walk.
struct OitPixelHead {
  uint head;      // node index + 1 of the last appended fragment, 0 = empty
  uint fragments; // every fragment of the pixel this frame (its rank when appended): the cap, MSL
  uint floorBits; // depth bits no farther than the pixel's farthest listed fragment once it is full
                  // (raised by atomicMax after a walk): a fragment at or beyond it is dropped unwalked
};

// One blended fragment of a pixel's list: its depth and a non-zero 32-bit id (cluster renderer:
// visibility id, shaded by the composite, or a particle's node index + 1 | MIRAGE_OIT_COLOR_ID_TAG;
// forward renderer: its own node index + 1, naming the colour stored beside it). 0 ends a list. Nodes outside this
// frame's lists are all zero (the pool is zeroed when made and oitGather zeroes every node it reads), so a zero depth
// or id also marks a node not written yet.
struct OitNode {
  uint depthBits; // reverse-Z depth as float bits (larger is nearer)
  uint id;
  uint next; // node index + 1 of the next fragment of the pixel, 0 at the end
};

// Counters of one frame's lists, zeroed at the frame start. Mean Squared Layers (the seed's
// transparency cost metric) = squaredLayers / coveredPixels, squaredLayers = hi << 32 | lo. Every
// fragment either asked the pool for a node (nodes) or came past its pixel's cap (capDropped), so
// the frame's fragments are nodes + capDropped; each one past the pool or past the cap lost one
// fragment (itself, or the farthest listed one it replaced).
struct OitCounters {
  uint nodes;           // fragments under their pixel's cap that asked for a node (may exceed the pool)
  uint layersDropped;   // resolve: listed fragments beyond its layer cap (the farthest of a pixel)
  uint coveredPixels;   // resolve: pixels with at least one fragment
  uint squaredLayersLo; // resolve: sum over pixels of (fragments)^2, 64 bits with carry
  uint squaredLayersHi;
  uint capDropped; // resolve: fragments past their pixel's MIRAGE_OIT_MAX_LAYERS (took no node)
};

// Marks an id naming a node whose shaded colour is stored beside the pool (OitLists::colorAddress)
// in lists whose other ids are visibility ids: the cluster renderer's particle fragments. Visibility
// ids stay below it (blend-list entries + 1 <= 2^22, shifted by the 7 triangle bits), and a tagged
// id stays below the overflow walk's lock value 0xffffffff (oit_list.glsl, kOitBusy): a pool is
// addressed by one storage buffer, so it holds fewer than 2^32 / 12 nodes.
#define MIRAGE_OIT_COLOR_ID_TAG 0x80000000u

// Lists of fragments shaded where they are rasterized (the forward renderer's, and the particle
// billboards' in either renderer; the cluster renderer keeps the same addresses in ClusterFrame):
// heads per pixel of a rowPixels-wide target, the pool, and beside each node its colour (uvec2:
// packHalf2x16 of rg, of ba).
struct OitLists {
  uint64_t headAddress;    // OitPixelHead[] per pixel
  uint64_t nodeAddress;    // OitNode[nodeCapacity]
  uint64_t colorAddress;   // uvec2[nodeCapacity]
  uint64_t counterAddress; // OitCounters
  uint rowPixels;          // target width (both eyes in stereo)
  uint height;
  uint nodeCapacity;
  uint idTag; // OR'd into each appended node's index + 1 to make its id: 0 (forward) or MIRAGE_OIT_COLOR_ID_TAG
};

#ifdef __cplusplus
static_assert(sizeof(OitNode) == 12, "OitNode layout");
static_assert(sizeof(OitCounters) == 24, "OitCounters layout");
static_assert(sizeof(OitPixelHead) == 12, "OitPixelHead layout");
static_assert(sizeof(OitLists) == 48, "OitLists layout");
static_assert((MIRAGE_OIT_COLOR_ID_TAG | (UINT32_MAX / sizeof(OitNode) + 1)) < UINT32_MAX,
              "a tagged node id never equals the overflow walk's lock value");
} // namespace mirage::shaderio
#endif

#endif
