#version 460
// Ranges of packed transparency storage (shaderio/oit.h, "Packed storage"; docs/render.md,
// "Transparency"), between the two rasterizations: from every pixel's fragment count, each pixel's
// first slot in the key pool, its slots and its state. Three dispatches (push.stage):
// 0. one workgroup per block of MIRAGE_OIT_RANGE_BLOCK pixels: the histogram of its pixels' counts
//    clamped at MIRAGE_OIT_MAX_LAYERS;
// 1. one workgroup: the frame's histogram gives the per-pixel cap that fits the pool (the cap
//    itself when the pool holds every pixel's nearest MIRAGE_OIT_MAX_LAYERS; else the largest c
//    whose sum of min(count, c) fits, the pool's rest going one more fragment each to the first
//    pixels over c, so the pool fills exactly and each pixel loses its farthest); then the blocks'
//    first slots, an exclusive scan over the blocks;
// 2. one workgroup per block: the scan within the block (8 consecutive pixels per thread), each
//    pixel's head (first slot) and state; a pixel with fewer slots than fragments has its slots
//    zeroed for the cascade of 64-bit maxima that keeps its nearest (oitPackedFragment).
// Stage 1 also zeroes the blend queue's counters for the second rasterization. After a fixed-slot
// rasterization (push.fixedSlots; shaderio/oit.h, MIRAGE_OIT_FIXED_*) stage 1 marks the first
// rasterization complete, and every stage returns at once unless a pixel had more fragments than
// its slots: then the counts it made are placed as ranges as after a count pass.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/oit.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { OitRangesPush push; };

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer HeadRef { OitPixelHead pixels[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer KeyRef { uint64_t keys[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer CounterRef { OitCounters counters; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer QueueCounterRef {
  uint words[MIRAGE_OIT_QUEUE_WORDS];
};
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ScratchRef {
  OitRangesScratch frame;
  uint words[]; // per block: MIRAGE_OIT_MAX_LAYERS + 1 counts, then (at kOffsets) uvec2 first slots
};

const uint kBins = MIRAGE_OIT_MAX_LAYERS + 1;
const uint kPerThread = MIRAGE_OIT_RANGE_BLOCK / 256u;

shared uint bins[kBins];
shared uvec2 scan[2][256];

uint blockCount() { return (push.pixels + MIRAGE_OIT_RANGE_BLOCK - 1u) / MIRAGE_OIT_RANGE_BLOCK; }
uint offsetsWord(uint block) { return blockCount() * kBins + 2u * block; } // a block's first slot

// Exclusive prefix sums of v over the workgroup (Hillis-Steele, double-buffered); `total` the sum.
uvec2 exclusiveScan(uvec2 v, out uvec2 total) {
  uint i = gl_LocalInvocationID.x, src = 0u;
  scan[src][i] = v;
  barrier();
  for (uint offset = 1u; offset < 256u; offset <<= 1) {
    uvec2 sum = scan[src][i] + (i >= offset ? scan[src][i - offset] : uvec2(0u));
    scan[src ^ 1u][i] = sum;
    src ^= 1u;
    barrier();
  }
  total = scan[src][255];
  uvec2 inclusive = scan[src][i];
  barrier(); // the next call may overwrite
  return inclusive - v;
}

// Keys kept (min(count, cap)) and pixels over the cap of a histogram.
uvec2 keptOver(uint hist[kBins], uint cap) {
  uvec2 r = uvec2(0u);
  for (uint k = 1u; k < kBins; ++k) r += hist[k] * uvec2(min(k, cap), k > cap ? 1u : 0u);
  return r;
}

void main() {
  ScratchRef scratch = ScratchRef(push.scratchAddress);
  HeadRef heads = HeadRef(push.headAddress);
  uint tid = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
  if (push.fixedSlots != 0u) { // after fixed slots: ranges only where some pixel had more fragments
    CounterRef counters = CounterRef(push.counterAddress);
    uint fixedState = counters.counters.fixedState; // uniform: the first rasterization is complete
    if (push.stage == 1u && tid == 0u) counters.counters.fixedState = fixedState | MIRAGE_OIT_FIXED_SECOND;
    if ((fixedState & MIRAGE_OIT_FIXED_OVER) == 0u) return;
  }
  if (push.stage == 1u && push.queueAddress != 0ul && tid < MIRAGE_OIT_QUEUE_WORDS)
    QueueCounterRef(push.queueAddress).words[tid] = 0u; // the second rasterization queues afresh
  if (push.stage == 0u) {
    if (tid < kBins) bins[tid] = 0u;
    barrier();
    for (uint k = 0u; k < kPerThread; ++k) {
      uint pixel = block * MIRAGE_OIT_RANGE_BLOCK + k * 256u + tid; // coalesced
      if (pixel < push.pixels) atomicAdd(bins[min(heads.pixels[pixel].fragments, kBins - 1u)], 1u);
    }
    barrier();
    if (tid < kBins) scratch.words[block * kBins + tid] = bins[tid];
  } else if (push.stage == 1u) {
    uint blocks = blockCount();
    if (tid < kBins) bins[tid] = 0u;
    barrier();
    for (uint k = 0u; k < kBins; ++k) {
      uint sum = 0u;
      for (uint b = tid; b < blocks; b += 256u) sum += scratch.words[b * kBins + k];
      if (sum != 0u) atomicAdd(bins[k], sum);
    }
    barrier();
    uint hist[kBins];
    for (uint k = 0u; k < kBins; ++k) hist[k] = bins[k];
    uint cap = MIRAGE_OIT_MAX_LAYERS, extra = 0u;
    uint all = keptOver(hist, cap).x; // every fragment under its pixel's cap
    if (all > push.capacity) {
      cap = 0u;
      while (keptOver(hist, cap + 1u).x <= push.capacity) ++cap;
      extra = push.capacity - keptOver(hist, cap).x; // fewer than the pixels over cap
    }
    if (tid == 0u) {
      scratch.frame = OitRangesScratch(cap, extra, blocks, 0u);
      CounterRef(push.counterAddress).counters.nodes = all;
    }
    // Each block's first slot: kept keys before it and pixels over the cap before it.
    uvec2 carry = uvec2(0u);
    for (uint first = 0u; first < blocks; first += 256u) {
      uint b = first + tid;
      uint h[kBins];
      for (uint k = 0u; k < kBins; ++k) h[k] = b < blocks ? scratch.words[b * kBins + k] : 0u;
      uvec2 total;
      uvec2 before = exclusiveScan(keptOver(h, cap), total) + carry;
      if (b < blocks) {
        scratch.words[offsetsWord(b)] = before.x;
        scratch.words[offsetsWord(b) + 1u] = before.y;
      }
      carry += total;
    }
  } else {
    OitRangesScratch frame = scratch.frame;
    uvec2 blockBefore = uvec2(scratch.words[offsetsWord(block)], scratch.words[offsetsWord(block) + 1u]);
    uint first = block * MIRAGE_OIT_RANGE_BLOCK + tid * kPerThread; // consecutive pixels per thread
    uint counts[kPerThread];
    uvec2 mine = uvec2(0u);
    for (uint k = 0u; k < kPerThread; ++k) {
      counts[k] = first + k < push.pixels ? heads.pixels[first + k].fragments : 0u;
      mine += uvec2(min(counts[k], frame.cap), counts[k] > frame.cap ? 1u : 0u);
    }
    uvec2 total;
    uvec2 before = exclusiveScan(mine, total) + blockBefore;
    KeyRef pool = KeyRef(push.keyAddress);
    for (uint k = 0u; k < kPerThread && first + k < push.pixels; ++k) {
      uint count = counts[k];
      bool over = count > frame.cap;
      uint slots = min(count, frame.cap) + (over && before.y < frame.extra ? 1u : 0u);
      uint base = before.x + min(before.y, frame.extra);
      before += uvec2(min(count, frame.cap), over ? 1u : 0u);
      bool nearest = count > slots;
      heads.pixels[first + k].head = base;
      heads.pixels[first + k].floorBits = MIRAGE_OIT_PACKED_READY | (nearest ? MIRAGE_OIT_PACKED_NEAREST | slots : 0u);
      if (nearest)
        for (uint i = 0u; i < slots; ++i) pool.keys[base + i] = 0ul;
    }
  }
}
