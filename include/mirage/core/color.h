#pragma once
// sRGB transfer function (IEC 61966-2-1), shared by image files and renderers' readbacks.
#include <cstdint>

namespace mirage {

// Clamps to [0, 1] (NaN -> 0) and rounds.
uint8_t linearToSrgb8(float linear);
// Exact per value (table).
float srgb8ToLinear(uint8_t encoded);

} // namespace mirage
