// Per-pixel linked lists of blended fragments (Yang et al. 2010), the one implementation of the
// forward renderer's and the cluster-LOD renderer's order-independent transparency (docs/render.md,
// "Transparency"): append under the pool rule, gather the nearest layers sorted, count the
// frame's Mean Squared Layers. Needs GL_EXT_buffer_reference, scalar block layout and 64-bit ints.
// An includer may define MIRAGE_OIT_LAYERS (the layer cap, default MIRAGE_OIT_MAX_LAYERS).
#extension GL_KHR_shader_subgroup_arithmetic : enable
#extension GL_KHR_shader_subgroup_ballot : enable

#include "mirage/shaderio/oit.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitNodeRef { OitNode nodes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitHeadRef { uint heads[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer OitCounterRef { OitCounters counters; };

const uint kOitNoNode = 0xffffffffu;

// The pool rule: a node index from the counter, which counts every attempt so that the excess is
// known; a fragment past the pool is dropped (kOitNoNode).
uint oitAllocate(uint64_t counterAddress, uint capacity) {
  uint n = atomicAdd(OitCounterRef(counterAddress).counters.nodes, 1);
  return n < capacity ? n : kOitNoNode;
}

// Node n (from oitAllocate) pushed onto pixel's list.
void oitLink(uint64_t headAddress, uint64_t nodeAddress, uint pixel, uint n, float z, uint id) {
  uint next = atomicExchange(OitHeadRef(headAddress).heads[pixel], n + 1);
  OitNodeRef(nodeAddress).nodes[n] = OitNode(floatBitsToUint(z), id, next);
}

#ifndef MIRAGE_OIT_LAYERS
#define MIRAGE_OIT_LAYERS MIRAGE_OIT_MAX_LAYERS
#endif

// oitGather's result: keys depth bits << 32 | id, ascending = far to near (reverse-Z), in
// oitKeys[0, count); unused keys stay 0 (id 0 names something valid: lavapipe loads for inactive
// lanes too).
uint64_t oitKeys[MIRAGE_OIT_LAYERS];

struct OitPixel {
  int count;    // keys kept
  uint fragments; // in the list
  uint dropped; // beyond the layer cap: the farthest, which blending "over" shows least
};

// The list starting at `node` (its head) walked once, keeping the nearest MIRAGE_OIT_LAYERS sorted
// by (depth, id) by insertion. At most `capacity` steps: a corrupt list cannot hang the pass.
OitPixel oitGather(uint64_t nodeAddress, uint capacity, uint node) {
  for (int i = 0; i < MIRAGE_OIT_LAYERS; ++i) oitKeys[i] = 0;
  OitPixel p = OitPixel(0, 0, 0);
  OitNodeRef nodes = OitNodeRef(nodeAddress);
  for (; node != 0 && p.fragments < capacity; ++p.fragments) {
    OitNode n = nodes.nodes[min(node - 1, capacity - 1)];
    node = n.next;
    uint64_t key = (uint64_t(n.depthBits) << 32) | uint64_t(n.id);
    int at;
    if (p.count < MIRAGE_OIT_LAYERS) {
      at = p.count++;
    } else {
      ++p.dropped;
      if (key <= oitKeys[0]) continue; // farther than every kept fragment
      for (int i = 0; i + 1 < MIRAGE_OIT_LAYERS; ++i) oitKeys[i] = oitKeys[i + 1]; // drop the farthest
      at = MIRAGE_OIT_LAYERS - 1;
    }
    for (; at > 0 && oitKeys[at - 1] > key; --at) oitKeys[at] = oitKeys[at - 1]; // insertion sort
    oitKeys[at] = key;
  }
  return p;
}

// A resolved pixel's share of the frame's counters (layers dropped, covered pixels, squared list
// length for Mean Squared Layers), summed over the subgroup first: one atomic per counter and
// subgroup rather than per pixel. Lists of 4096+ fragments (squares past 24 bits, whose subgroup
// sum could wrap) add their own 64-bit square. Call from every pixel with a non-empty list.
void oitCountPixel(uint64_t counterAddress, OitPixel p) {
  bool long_ = p.fragments >= 4096u;
  uint square = long_ ? 0u : p.fragments * p.fragments;
  uint squares = subgroupAdd(square);
  uint dropped = subgroupAdd(p.dropped);
  uint covered = subgroupAdd(1u);
  OitCounterRef c = OitCounterRef(counterAddress);
  if (subgroupElect()) {
    atomicAdd(c.counters.coveredPixels, covered);
    if (dropped != 0) atomicAdd(c.counters.layersDropped, dropped);
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
