#include "mirage/render/render_size.h"

#include <charconv>

#include <fmt/format.h>

#include "mirage/render/forward_renderer.h"

namespace mirage::render {

Status parseRenderSize(std::string_view text, uint32_t& width, uint32_t& height) {
  size_t x = text.find('x');
  auto bad = Error{fmt::format("--size '{}': expected WxH with 1..{} each", text, kMaxRenderDimension)};
  if (x == std::string_view::npos) return bad;
  const char* s = text.data();
  auto r1 = std::from_chars(s, s + x, width);
  auto r2 = std::from_chars(s + x + 1, s + text.size(), height);
  if (r1.ec != std::errc() || r1.ptr != s + x || r2.ec != std::errc() || r2.ptr != s + text.size()) return bad;
  if (width == 0 || height == 0 || width > kMaxRenderDimension || height > kMaxRenderDimension) return bad;
  return Ok{};
}

} // namespace mirage::render
