#pragma once
#include <cstdint>

namespace mirage::render {

// Frames a caller may have recorded and not yet collected (record/collect slots 0..2), for every
// renderer with a record/collect API (ClusterRenderer, SurfelRenderer, ForwardRenderer).
inline constexpr uint32_t kMaxFramesInFlight = 3;

} // namespace mirage::render
