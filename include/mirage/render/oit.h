#pragma once
// Order-independent transparency of the forward and cluster-LOD renderers (docs/render.md,
// "Transparency"): the modes and the per-frame counters both report.
#include <cstdint>
#include <string_view>

#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/shaderio/oit.h"

namespace mirage::render {

enum class OitMode {
  Auto,       // the renderer's default: fixed for cluster LOD, linked lists for the forward renderer
  LinkedList, // per-pixel linked lists, nearest MIRAGE_OIT_MAX_LAYERS sorted per pixel (both renderers)
  // Per-pixel contiguous ranges (cluster LOD): the blend rasters run twice, counting then writing
  // each pixel's fragments into its range of a pool of 64-bit keys sized by a scan over the pixels;
  // the same fragments kept and the same image as the linked lists (shaderio/oit.h).
  Packed,
  // Packed storage in fixed slots (cluster LOD's default): each pixel the pool's keys per pixel (at
  // most 16), one rasterization writing each fragment at its rank; where some pixel has more
  // fragments than its slots, the frame continues as Packed (the same keys kept, the same image).
  Fixed,
  Weighted, // weighted blended OIT (McGuire and Bavoil 2013): approximate, no lists (forward)
  Sorted,   // the exact reference: every blended triangle sorted back to front on the CPU (forward)
};
inline constexpr EnumName<OitMode> kOitModeNames[] = {
    {OitMode::Auto, "auto"},   {OitMode::LinkedList, "linked-list"}, {OitMode::Packed, "packed"},
    {OitMode::Fixed, "fixed"}, {OitMode::Weighted, "weighted"},      {OitMode::Sorted, "sorted"}};
const char* toString(OitMode mode);
// "auto", "linked-list", "packed", "fixed", "weighted" or "sorted"; anything else is an error naming the choices.
Result<OitMode> parseOitMode(std::string_view text);

// One frame's transparency counters (zero without blended geometry or outside linked-list mode).
// Every fragment lost is counted once, in one of three parts (dropped()): past the pool, past its
// pixel's cap (both at append: each loses its pixel's farthest, itself or one it replaces), or
// listed beyond the resolve's layers (zero while the resolve keeps as many as the cap).
struct OitStats {
  uint32_t fragments = 0; // blended fragments in front of the opaque depth
  // Of those under their pixel's cap, beyond the node pool (packed: the pool then holds exactly
  // the nearest it can, each pixel losing its farthest; fragments - capDropped is the pool that
  // would have kept them all).
  uint32_t poolOverflow = 0;
  uint32_t capDropped = 0;    // past their pixel's MIRAGE_OIT_MAX_LAYERS (took no node)
  uint32_t layersDropped = 0; // listed beyond the resolve's layer cap of their pixel (its farthest)
  uint32_t coveredPixels = 0; // pixels with at least one fragment
  double msl = 0.0;           // Mean Squared Layers: squared fragment count averaged over covered pixels
  uint64_t dropped() const { return uint64_t(poolOverflow) + capDropped + layersDropped; }
};
OitStats oitStats(const shaderio::OitCounters& counters, uint32_t nodeCapacity);

} // namespace mirage::render
