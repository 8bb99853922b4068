// Per-pixel linked lists of blended fragments (Yang et al. 2010), the one implementation of the
// forward renderer's and the cluster-LOD renderer's order-independent transparency (docs/render.md,
// "Transparency"): append under the pool rule and the per-pixel cap (past either, the farthest
// fragment of the pixel is the one lost), gather the nearest layers sorted, count the frame's Mean
// Squared Layers; and the packed storage (shaderio/oit.h: each pixel's fragments in one contiguous
// range, written by a second rasterization). Needs GL_EXT_buffer_reference, scalar block layout and
// 64-bit ints (the packed writes 64-bit buffer atomics). An includer may define MIRAGE_OIT_LAYERS
// (the layers a gather keeps, default MIRAGE_OIT_MAX_LAYERS).
#extension GL_KHR_shader_subgroup_arithmetic : enable
#extension GL_KHR_shader_subgroup_ballot : enable
#extension GL_EXT_control_flow_attributes : enable
#extension GL_EXT_shader_atomic_int64 : enable

#include "mirage/shaderio/oit.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitNodeRef { OitNode nodes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitHeadRef { OitPixelHead pixels[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitCounterRef { OitCounters counters; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer OitKeyRef { uint64_t keys[]; };
// The same lists read while other invocations append and replace (the overflow walk): coherent, so
// the reads see other invocations' writes rather than a stale cached copy.
layout(buffer_reference, scalar, buffer_reference_align = 4) coherent buffer OitNodeSharedRef { OitNode nodes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) coherent buffer OitHeadSharedRef {
  OitPixelHead pixels[];
};

const uint kOitNoNode = 0xffffffffu;
const uint kOitBusy = 0xffffffffu; // a node's id while a fragment replacing it rewrites the node

// A fragment of `pixel` counted (every one: MSL, the cap); returns how many came before it.
uint oitCountFragment(uint64_t headAddress, uint pixel) {
  return atomicAdd(OitHeadRef(headAddress).pixels[pixel].fragments, 1u);
}

// Node n pushed onto pixel's list.
void oitLink(uint64_t headAddress, uint64_t nodeAddress, uint pixel, uint n, float z, uint id) {
  uint next = atomicExchange(OitHeadRef(headAddress).pixels[pixel].head, n + 1);
  OitNodeRef(nodeAddress).nodes[n] = OitNode(floatBitsToUint(z), id, next);
}

// The rule past the pool or past the pixel's cap: a fragment takes the place of its pixel's
// farthest listed fragment if that one is farther than itself ("over" shows the farthest least),
// else it is the one dropped; either way one fragment per such attempt is lost, as OitCounters
// counts. First the pixel's floor (OitPixelHead::floorBits): at or beyond it, dropped with one
// load. Else the walk (at most MIRAGE_OIT_REPLACE_STEPS nodes from the head; the cap keeps a list
// at most MIRAGE_OIT_MAX_LAYERS long) skips nodes not written yet (all zero: oitGather leaves the
// pool so) and nodes being replaced; the node found is locked by swapping its id for kOitBusy, and
// if it changed meanwhile the walk restarts (at most MIRAGE_OIT_REPLACE_TRIES walks). The floor is
// then raised to the farthest depth still listed (the second farthest seen, or this fragment), or,
// nothing farther found, to the farthest listed. Returns the locked node, to be rewritten by
// oitReplace, or kOitNoNode (the fragment is dropped). Appends still in flight may hide a node from
// a walk (and so from the floor), so under contention the node replaced may not be the farthest,
// or a fragment may be dropped while a farther one stays; a pixel that got no node before the pool
// filled keeps none.
uint oitClaimFarthest(uint64_t headAddress, uint64_t nodeAddress, uint capacity, uint pixel, float z) {
  OitNodeSharedRef nodes = OitNodeSharedRef(nodeAddress);
  OitHeadSharedRef heads = OitHeadSharedRef(headAddress);
  uint zBits = floatBitsToUint(z);
  uint floorBits = heads.pixels[pixel].floorBits;
  if (zBits <= floorBits) return kOitNoNode; // no farther than the farthest listed: dropped unwalked
  for (int attempt = 0; attempt < MIRAGE_OIT_REPLACE_TRIES; ++attempt) {
    uint node = heads.pixels[pixel].head;
    // The farthest listed node (victim) and the second farthest depth; depth bits order like the
    // depths (positive floats); reverse-Z: smaller is farther.
    uint victim = kOitNoNode, victimDepth = 0xffffffffu, victimId = 0, secondDepth = 0xffffffffu;
    for (int step = 0; node != 0 && step < MIRAGE_OIT_REPLACE_STEPS; ++step) {
      uint i = min(node - 1, capacity - 1);
      uint depthBits = nodes.nodes[i].depthBits, id = nodes.nodes[i].id;
      node = nodes.nodes[i].next;
      if (depthBits == 0 || id == 0 || id == kOitBusy) continue;
      if (depthBits < victimDepth) {
        secondDepth = victimDepth;
        victim = i;
        victimDepth = depthBits;
        victimId = id;
      } else {
        secondDepth = min(secondDepth, depthBits);
      }
    }
    if (victim == kOitNoNode || victimDepth >= zBits) { // nothing listed lies farther: this fragment is dropped
      if (victim != kOitNoNode && victimDepth > floorBits) atomicMax(heads.pixels[pixel].floorBits, victimDepth);
      return kOitNoNode;
    }
    if (atomicCompSwap(nodes.nodes[victim].id, victimId, kOitBusy) != victimId) continue; // taken: walk again
    memoryBarrierBuffer(); // the depth written by the node's last replacement is visible
    if (nodes.nodes[victim].depthBits == victimDepth) {
      uint listed = min(secondDepth, zBits); // the farthest once this fragment replaced the victim
      if (listed > floorBits) atomicMax(heads.pixels[pixel].floorBits, listed);
      return victim;
    }
    atomicExchange(nodes.nodes[victim].id, victimId); // replaced meanwhile (same id): unlock, walk again
  }
  return kOitNoNode;
}

// A node locked by oitClaimFarthest rewritten with this fragment, then unlocked (its id written
// last, after the depth and the caller's payload).
void oitReplace(uint64_t nodeAddress, uint node, float z, uint id) {
  OitNodeSharedRef nodes = OitNodeSharedRef(nodeAddress);
  nodes.nodes[node].depthBits = floatBitsToUint(z);
  memoryBarrierBuffer();
  atomicExchange(nodes.nodes[node].id, id);
}

// Where a fragment goes: a fresh node (n, from the pool counter) or, past the pool (n >= capacity)
// or past its pixel's cap (n = kOitNoNode: it asked for none), its pixel's farthest node
// (oitClaimFarthest); node kOitNoNode: dropped. Write any payload indexed by the node, then oitCommit.
struct OitSlot {
  uint node;
  bool fresh; // a new node, linked by oitCommit; else a listed node, rewritten in place
};
OitSlot oitSlotOf(uint n, uint64_t headAddress, uint64_t nodeAddress, uint capacity, uint pixel, float z) {
  if (n < capacity) return OitSlot(n, true);
  return OitSlot(oitClaimFarthest(headAddress, nodeAddress, capacity, pixel, z), false);
}

// A fragment of `pixel` at depth z counted, and placed: under its pixel's cap a node from the pool
// counter (which counts every such attempt, so the excess is known), else oitSlotOf's rule.
OitSlot oitAcquire(uint64_t counterAddress, uint64_t headAddress, uint64_t nodeAddress, uint capacity, uint pixel,
                   float z) {
  uint n = kOitNoNode;
  if (oitCountFragment(headAddress, pixel) < MIRAGE_OIT_MAX_LAYERS)
    n = atomicAdd(OitCounterRef(counterAddress).counters.nodes, 1);
  return oitSlotOf(n, headAddress, nodeAddress, capacity, pixel, z);
}

// oitAcquire in steps, one counter atomic per subgroup for many fragments (the blend queue: 8
// full-screen layers are 16.6 M fragments at 1080p, which would serialize on the one counter):
// each fragment counted first (oitCountFragment: under the cap or not), then every invocation of
// the subgroup calls oitAllocateSubgroup with the subgroup's count of fragments under their cap
// (subgroup-uniform control flow) and gets the first node of the subgroup's run; each such
// fragment's node is then that plus its rank in the run, the others' kOitNoNode, placed by oitSlotOf.
uint oitAllocateSubgroup(uint64_t counterAddress, uint count) {
  uint base = 0;
  if (count != 0) { // uniform over the subgroup
    if (subgroupElect()) base = atomicAdd(OitCounterRef(counterAddress).counters.nodes, count);
    base = subgroupBroadcastFirst(base); // the elected invocation is the first active one
  }
  return base;
}

// The fragment written into its slot: a fresh node linked onto the pixel's list, a claimed node
// rewritten and unlocked. `payload`: the caller wrote data indexed by the node (the forward
// renderer's colour) that a later replacement of this node must not see land after its own, so a
// fresh node is published only once that data is visible.
void oitCommit(uint64_t headAddress, uint64_t nodeAddress, uint pixel, OitSlot s, float z, uint id, bool payload) {
  if (s.fresh) {
    if (payload) memoryBarrierBuffer();
    oitLink(headAddress, nodeAddress, pixel, s.node, z, id);
  } else {
    oitReplace(nodeAddress, s.node, z, id);
  }
}

// A fragment of `pixel` at depth z in packed storage (shaderio/oit.h), either pass: before the
// ranges pass (the pixel's state not READY) only counted; after it written into the pixel's range:
// at the cursor where the range holds every fragment (the same fragments as pass 1, so the cursor
// stays below the count; the test only guards a range from its neighbours), else by the cascade
// that keeps the range's keys the nearest so far, sorted nearest first: each slot takes the larger
// (nearer) of its key and the one arriving, the smaller one moves on to the next slot (atomicMax:
// the kept set does not depend on the order of arrival).
void oitPackedFragment(uint64_t headAddress, uint64_t keyAddress, uint pixel, float z, uint id) {
  OitHeadRef heads = OitHeadRef(headAddress);
  uint state = heads.pixels[pixel].floorBits;
  if ((state & MIRAGE_OIT_PACKED_READY) == 0u) { // pass 1
    atomicAdd(heads.pixels[pixel].fragments, 1u);
    return;
  }
  uint base = heads.pixels[pixel].head;
  uint64_t key = (uint64_t(floatBitsToUint(z)) << 32) | uint64_t(id);
  OitKeyRef pool = OitKeyRef(keyAddress);
  if ((state & MIRAGE_OIT_PACKED_NEAREST) == 0u) {
    uint slot = atomicAdd(heads.pixels[pixel].floorBits, 1u) & MIRAGE_OIT_PACKED_COUNT;
    if (slot < heads.pixels[pixel].fragments) pool.keys[base + slot] = key;
    return;
  }
  uint slots = state & MIRAGE_OIT_PACKED_COUNT;
  for (uint i = 0u; i < slots && key != 0ul; ++i) key = min(key, atomicMax(pool.keys[base + i], key));
}

// A fragment of `pixel` in fixed slots, the first rasterization (shaderio/oit.h,
// MIRAGE_OIT_FIXED_*): counted on its pixel, and written into its slot rank * stride + pixel (its
// rank: the pixel's fragments before it) while the rank is under `slots`. The first one past them
// marks the frame (once per pixel at most; a cached read spares most of the atomics), whose
// fragments the ranges pass and the second rasterization then place again as packed storage.
void oitFixedFragment(uint64_t headAddress, uint64_t keyAddress, uint64_t counterAddress, uint slots, uint stride,
                      uint pixel, float z, uint id) {
  uint rank = atomicAdd(OitHeadRef(headAddress).pixels[pixel].fragments, 1u);
  if (rank < slots) {
    OitKeyRef(keyAddress).keys[rank * stride + pixel] = (uint64_t(floatBitsToUint(z)) << 32) | uint64_t(id);
  } else if (rank == slots) {
    OitCounterRef c = OitCounterRef(counterAddress);
    if ((c.counters.fixedState & MIRAGE_OIT_FIXED_OVER) == 0u) atomicOr(c.counters.fixedState, MIRAGE_OIT_FIXED_OVER);
  }
}

#ifndef MIRAGE_OIT_LAYERS
#define MIRAGE_OIT_LAYERS MIRAGE_OIT_MAX_LAYERS
#endif

// oitGather's result: keys depth bits << 32 | id, ascending = far to near (reverse-Z), in
// oitKeys[0, count); unused keys stay 0 (id 0 names something valid: lavapipe loads for inactive
// lanes too).
uint64_t oitKeys[MIRAGE_OIT_LAYERS];

struct OitPixel {
  int count;      // keys kept
  uint fragments; // of the pixel this frame (OitPixelHead::fragments), listed or not
  uint dropped;   // listed beyond the layer cap: the farthest, which blending "over" shows least
};

// Key `key` (depth bits << 32 | id) offered to the kept ones in oitKeys: by insertion, the
// farthest dropped (and counted) once MIRAGE_OIT_LAYERS are kept.
void oitKeep(inout OitPixel p, uint64_t key) {
  int at;
  if (p.count < MIRAGE_OIT_LAYERS) {
    at = p.count++;
  } else {
    ++p.dropped;
    if (key <= oitKeys[0]) return;                                               // farther than every kept fragment
    for (int i = 0; i + 1 < MIRAGE_OIT_LAYERS; ++i) oitKeys[i] = oitKeys[i + 1]; // drop the farthest
    at = MIRAGE_OIT_LAYERS - 1;
  }
  for (; at > 0 && oitKeys[at - 1] > key; --at) oitKeys[at] = oitKeys[at - 1]; // insertion sort
  oitKeys[at] = key;
}

// One step of a list walk: node `node` (index + 1, non-zero) read and zeroed, so the pool is all
// zero again for the next frame's overflow walks (oitClaimFarthest), which must tell a node not
// written yet from a listed one; returns its key depth bits << 32 | id and moves `node` to the next.
uint64_t oitTakeNode(uint64_t nodeAddress, uint capacity, inout uint node) {
  uint index = min(node - 1, capacity - 1);
  OitNode n = OitNodeRef(nodeAddress).nodes[index];
  OitNodeRef(nodeAddress).nodes[index] = OitNode(0u, 0u, 0u);
  node = n.next;
  return (uint64_t(n.depthBits) << 32) | uint64_t(n.id);
}

// The list of pixel `h` walked once from its head, keeping the nearest MIRAGE_OIT_LAYERS sorted by
// (depth, id) by insertion. At most `capacity` steps: a corrupt list cannot hang the pass. Each
// node read is zeroed (oitTakeNode).
OitPixel oitGather(uint64_t nodeAddress, uint capacity, OitPixelHead h) {
  for (int i = 0; i < MIRAGE_OIT_LAYERS; ++i) oitKeys[i] = 0;
  OitPixel p = OitPixel(0, h.fragments, 0);
  uint node = h.head;
  for (uint steps = 0; node != 0 && steps < capacity; ++steps) oitKeep(p, oitTakeNode(nodeAddress, capacity, node));
  return p;
}

// Packed storage's keys sorted in registers (the composite; docs/render.md, "Packed storage"): a
// pixel holds at most MIRAGE_OIT_MAX_LAYERS keys in one range, so they are loaded by wide
// independent loads into an array indexed by constants only (a dynamically indexed array becomes
// local memory on NVIDIA) and sorted by Batcher's odd-even merge network (Knuth, TAOCP 5.3.4) for
// 4, 8 or 16 keys, whichever holds the range: the same order as oitKeep's insertion sort.
#define OIT_SORT_KEYS 16 // MIRAGE_OIT_MAX_LAYERS: a range's keys at most
#if MIRAGE_OIT_MAX_LAYERS != OIT_SORT_KEYS
#error "the sorting networks below are written for 16 keys"
#endif
const uint64_t kOitNoKey = 0xffffffffffffffffUL; // padding: sorts after every key (depth bits <= 1.0f's)

layout(buffer_reference, scalar, buffer_reference_align = 16) readonly buffer OitKeyPairRef { u64vec2 pairs[]; };

// Keys k[i] and k[j], i < j constants, put in order.
#define OIT_CX(k, i, j)                                                                                        \
  {                                                                                                            \
    uint64_t lo_ = min(k[i], k[j]);                                                                            \
    k[j] = max(k[i], k[j]);                                                                                    \
    k[i] = lo_;                                                                                                \
  }
// Keys o..o+3 sorted (5 exchanges).
#define OIT_SORT4(k, o)                                                                                        \
  OIT_CX(k, o, o + 1) OIT_CX(k, o + 2, o + 3) OIT_CX(k, o, o + 2) OIT_CX(k, o + 1, o + 3) OIT_CX(k, o + 1, o + 2)
// Keys o..o+7, each half sorted, merged (9 exchanges).
#define OIT_MERGE8(k, o)                                                                                       \
  OIT_CX(k, o, o + 4) OIT_CX(k, o + 1, o + 5) OIT_CX(k, o + 2, o + 6) OIT_CX(k, o + 3, o + 7)                  \
  OIT_CX(k, o + 2, o + 4) OIT_CX(k, o + 3, o + 5) OIT_CX(k, o + 1, o + 2) OIT_CX(k, o + 3, o + 4)              \
  OIT_CX(k, o + 5, o + 6)

// k[0, 16) sorted ascending (far to near), given that k[n, 16) hold kOitNoKey: the 4-key network
// (5 exchanges) when n <= 4, the 8-key one (19) when n <= 8, else the 16-key one (63).
void oitSortKeys(inout uint64_t k[OIT_SORT_KEYS], uint n) {
  OIT_SORT4(k, 0)
  if (n <= 4u) return;
  OIT_SORT4(k, 4)
  OIT_MERGE8(k, 0)
  if (n <= 8u) return;
  OIT_SORT4(k, 8)
  OIT_SORT4(k, 12)
  OIT_MERGE8(k, 8)
  OIT_CX(k, 0, 8) OIT_CX(k, 1, 9) OIT_CX(k, 2, 10) OIT_CX(k, 3, 11) OIT_CX(k, 4, 12) OIT_CX(k, 5, 13)
  OIT_CX(k, 6, 14) OIT_CX(k, 7, 15) OIT_CX(k, 4, 8) OIT_CX(k, 5, 9) OIT_CX(k, 6, 10) OIT_CX(k, 7, 11)
  OIT_CX(k, 2, 4) OIT_CX(k, 3, 5) OIT_CX(k, 6, 8) OIT_CX(k, 7, 9) OIT_CX(k, 10, 12) OIT_CX(k, 11, 13)
  OIT_CX(k, 1, 2) OIT_CX(k, 3, 4) OIT_CX(k, 5, 6) OIT_CX(k, 7, 8) OIT_CX(k, 9, 10) OIT_CX(k, 11, 12)
  OIT_CX(k, 13, 14)
}

// k[0, n) as read (0: a slot never written), the rest anything: keys never written and every slot
// past n made kOitNoKey, then sorted (oitSortKeys); returns the keys kept.
uint oitKeepSorted(inout uint64_t k[OIT_SORT_KEYS], uint n) {
  uint kept = 0u;
  [[unroll]] for (uint i = 0u; i < OIT_SORT_KEYS; ++i) {
    bool valid = i < n && k[i] != 0ul;
    k[i] = valid ? k[i] : kOitNoKey;
    kept += valid ? 1u : 0u;
  }
  oitSortKeys(k, n);
  return kept;
}

// Keys [base, base + n) of the pool (n <= OIT_SORT_KEYS) into k, sorted ascending (far to near),
// the rest kOitNoKey; keys never written (0) are left out as oitKeep leaves them. Returns the keys
// kept. The loads are independent 16-byte pairs from the even slot at or below base (an odd base
// reads one slot before its range, and one past it at most: inside the pool's buffer, which holds
// 12 bytes per key).
uint oitSortedRange(uint64_t keyAddress, uint base, uint n, out uint64_t k[OIT_SORT_KEYS]) {
  OitKeyPairRef pool = OitKeyPairRef(keyAddress);
  uint odd = base & 1u, first = base >> 1;
  uint64_t a[OIT_SORT_KEYS + 2];
  [[unroll]] for (uint j = 0u; j < OIT_SORT_KEYS / 2u + 1u; ++j) {
    u64vec2 pair = u64vec2(0ul);
    if (2u * j < n + odd) pair = pool.pairs[first + j];
    a[2u * j] = pair.x;
    a[2u * j + 1u] = pair.y;
  }
  [[unroll]] for (uint i = 0u; i < OIT_SORT_KEYS; ++i) k[i] = odd != 0u ? a[i + 1u] : a[i];
  return oitKeepSorted(k, n);
}

// The keys of `pixel` in fixed slots (shaderio/oit.h, MIRAGE_OIT_FIXED_*): slot i at
// i * stride + pixel (i < n <= OIT_SORT_KEYS), sorted and returned as oitSortedRange does. The
// loads are independent, and a warp's neighbouring pixels read neighbouring words (coalesced).
uint oitSortedSlots(uint64_t keyAddress, uint pixel, uint stride, uint n, out uint64_t k[OIT_SORT_KEYS]) {
  OitKeyRef pool = OitKeyRef(keyAddress);
  [[unroll]] for (uint i = 0u; i < OIT_SORT_KEYS; ++i) {
    k[i] = 0ul;
    if (i < n) k[i] = pool.keys[i * stride + pixel];
  }
  return oitKeepSorted(k, n);
}

// A resolved pixel's share of the frame's counters (listed layers dropped, fragments past the cap,
// covered pixels, squared fragment count for Mean Squared Layers: the exact count, not the capped
// list's length), summed over the subgroup first: one atomic per counter and subgroup rather than
// per pixel. Pixels of 4096+ fragments (squares past 24 bits, whose subgroup sum could wrap) add
// their own 64-bit square. `requests`: the pixel's fragments under the cap are added to
// OitCounters::nodes too (fixed slots: no append or ranges pass counted them). Call from every
// pixel with a fragment.
void oitCountPixel(uint64_t counterAddress, OitPixel p, bool requests) {
  bool long_ = p.fragments >= 4096u;
  uint square = long_ ? 0u : p.fragments * p.fragments;
  uint squares = subgroupAdd(square);
  uint dropped = subgroupAdd(p.dropped);
  uint pastCap = subgroupAdd(p.fragments - min(p.fragments, uint(MIRAGE_OIT_MAX_LAYERS)));
  uint covered = subgroupAdd(1u);
  uint nodes = subgroupAdd(requests ? min(p.fragments, uint(MIRAGE_OIT_MAX_LAYERS)) : 0u);
  OitCounterRef c = OitCounterRef(counterAddress);
  if (subgroupElect()) {
    atomicAdd(c.counters.coveredPixels, covered);
    if (nodes != 0) atomicAdd(c.counters.nodes, nodes);
    if (dropped != 0) atomicAdd(c.counters.layersDropped, dropped);
    if (pastCap != 0) atomicAdd(c.counters.capDropped, pastCap);
    uint old = atomicAdd(c.counters.squaredLayersLo, squares);
    if (old + squares < old) atomicAdd(c.counters.squaredLayersHi, 1u); // carry
  }
  if (long_) {
    uint64_t sq = uint64_t(p.fragments) * uint64_t(p.fragments);
    uint lo = uint(sq & 0xffffffffUL);
    uint old = atomicAdd(c.counters.squaredLayersLo, lo);
    atomicAdd(c.counters.squaredLayersHi, uint(sq >> 32) + (old + lo < old ? 1u : 0u));
  }
}

// "Over" of one fragment on the colour behind it, back to front: SRC_ALPHA / ONE_MINUS_SRC_ALPHA.
vec3 oitBlend(vec3 behind, vec4 c) { return mix(behind, c.rgb, c.a); }
