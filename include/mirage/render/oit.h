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
  LinkedList, // per-pixel linked lists, nearest MIRAGE_OIT_MAX_LAYERS sorted per pixel (both renderers)
  Weighted,   // weighted blended OIT (McGuire and Bavoil 2013): approximate, no lists (forward)
  Sorted,     // the exact reference: every blended triangle sorted back to front on the CPU (forward)
};
inline constexpr EnumName<OitMode> kOitModeNames[] = {
    {OitMode::LinkedList, "linked-list"}, {OitMode::Weighted, "weighted"}, {OitMode::Sorted, "sorted"}};
const char* toString(OitMode mode);
// "linked-list", "weighted" or "sorted"; anything else is an error naming the choices.
Result<OitMode> parseOitMode(std::string_view text);

// One frame's transparency counters (zero without blended geometry or outside linked-list mode).
struct OitStats {
  uint32_t fragments = 0;     // blended fragments in front of the opaque depth (appended)
  uint32_t poolOverflow = 0;  // of those, beyond the node pool (dropped as they came)
  uint32_t layersDropped = 0; // beyond the layer cap of their pixel (its farthest, dropped)
  uint32_t coveredPixels = 0; // pixels with at least one fragment
  double msl = 0.0;           // Mean Squared Layers: squared list length averaged over covered pixels
  uint64_t dropped() const { return uint64_t(poolOverflow) + layersDropped; }
};
OitStats oitStats(const shaderio::OitCounters& counters, uint32_t nodeCapacity);

} // namespace mirage::render
