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
  // Packed storage in fixed slots (ClusterFrame::oitFixedSlots): MIRAGE_OIT_FIXED_* bits.
  uint fixedState;
  uint pad;
};

// Packed storage (--oit packed; oit_list.glsl, oit_ranges.comp): each pixel's fragments in one
// contiguous range of a pool of 64-bit keys (depth bits << 32 | id), in two rasterizations. Pass 1
// counts every fragment on its pixel (OitPixelHead::fragments); the ranges pass (a scan over the
// pixels) gives each pixel `slots` keys from `head` on and sets `floorBits` to the pixel's state:
// MIRAGE_OIT_PACKED_READY | a cursor from 0 where it has a slot for each fragment (at most
// MIRAGE_OIT_MAX_LAYERS), or READY | NEAREST | slots where it has fewer (past the cap, or the pool
// short): its slots, zeroed by the ranges pass, then keep the nearest of its fragments by a cascade
// of 64-bit atomicMax. Pass 2 writes each fragment into its pixel's range.
#define MIRAGE_OIT_PACKED_READY 0x80000000u   // the ranges are set: a fragment writes (pass 2)
#define MIRAGE_OIT_PACKED_NEAREST 0x40000000u // fewer slots than fragments: the nearest kept
#define MIRAGE_OIT_PACKED_COUNT 0x3fffffffu   // the cursor, or (NEAREST) the slots
// Pixels per workgroup of the ranges pass (256 threads, 8 consecutive pixels each).
#define MIRAGE_OIT_RANGE_BLOCK 2048u

// Packed storage in fixed slots (--oit fixed; ClusterFrame::oitFixedSlots = K, the pool's keys per
// pixel, at most MIRAGE_OIT_MAX_LAYERS): one rasterization counts each fragment on its pixel and
// writes it into slot r = its rank, at r * pixels + pixel (slot-major: a warp's neighbouring
// pixels of one layer write, and the composite reads, neighbouring words), no count pass and no
// ranges. A pixel whose fragments
// outnumber K (the first past them sets MIRAGE_OIT_FIXED_OVER) would lose some that the counted
// ranges keep, so then, and only then, the ranges pass and the second rasterization run as for
// packed storage and place every fragment again (the same keys kept, the same image). Both are
// recorded every frame; the ranges pass's stage 1 sets MIRAGE_OIT_FIXED_SECOND, and the ranges
// stages, the second compute blend raster and the blend queue's second dispatch do nothing
// without MIRAGE_OIT_FIXED_OVER. The composite reads a pixel in fixed slots where its state is
// not MIRAGE_OIT_PACKED_READY.
#define MIRAGE_OIT_FIXED_OVER 1u   // some pixel has more fragments than its fixed slots
#define MIRAGE_OIT_FIXED_SECOND 2u // the first rasterization is complete

// The ranges pass (oit_ranges.comp), push.stage 0: each block's histogram of its pixels' counts
// (clamped at MIRAGE_OIT_MAX_LAYERS); 1 (one workgroup): the per-pixel cap that fits the pool,
// each block's first slot; 2: each pixel's range and state. The scratch holds per block
// MIRAGE_OIT_MAX_LAYERS + 1 counts then its first slot and its count of pixels given one slot
// more than the cap (OitRangesScratch after the blocks' histograms).
struct OitRangesPush {
  uint64_t headAddress;    // OitPixelHead[pixels]
  uint64_t keyAddress;     // uint64_t[capacity]
  uint64_t scratchAddress; // OitRangesScratch, then per block uint[MIRAGE_OIT_MAX_LAYERS + 1], uvec2 offsets
  uint64_t counterAddress; // OitCounters: `nodes` set to the fragments under their pixel's cap
  // The blend queue's counters (MIRAGE_OIT_QUEUE_WORDS words), zeroed by stage 1 so the second
  // rasterization queues its large triangles afresh; 0 without a blend queue.
  uint64_t queueAddress;
  uint pixels;
  uint capacity; // keys in the pool
  uint stage;
  uint fixedSlots; // fixed slots per pixel of the first rasterization (MIRAGE_OIT_FIXED_*), 0: counted ranges
};
// 32-bit words of the blend queue's counters zeroed between the rasterizations (ClusterCounters:
// blendQueueCounts, blendQueueArgs, blendQueueOverflow).
#define MIRAGE_OIT_QUEUE_WORDS 6u

// What stage 1 decides for the whole frame: the per-pixel cap that fits the pool (every pixel
// keeps its nearest min(fragments, cap), MIRAGE_OIT_MAX_LAYERS when the pool holds all), and how
// many pixels over it (in pixel order) keep one fragment more, so the kept total is the pool's
// size exactly when it is short.
struct OitRangesScratch {
  uint cap;
  uint extra;
  uint blocks;
  uint pad;
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
static_assert(sizeof(OitCounters) == 32, "OitCounters layout");
static_assert(sizeof(OitPixelHead) == 12, "OitPixelHead layout");
static_assert(sizeof(OitLists) == 48, "OitLists layout");
static_assert(sizeof(OitRangesPush) == 56, "OitRangesPush layout");
static_assert(sizeof(OitRangesScratch) == 16, "OitRangesScratch layout");
static_assert((MIRAGE_OIT_COLOR_ID_TAG | (UINT32_MAX / sizeof(OitNode) + 1)) < UINT32_MAX,
              "a tagged node id never equals the overflow walk's lock value");
} // namespace mirage::shaderio
#endif

#endif
