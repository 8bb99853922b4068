#pragma once
// The `--size WxH` of every command and the viewer, parsed once.
#include <cstdint>
#include <string_view>

#include "mirage/core/result.h"

namespace mirage::render {

// "WxH" with 1 <= W, H <= kMaxRenderDimension; the error names --size and the accepted range.
Status parseRenderSize(std::string_view text, uint32_t& width, uint32_t& height);

} // namespace mirage::render
