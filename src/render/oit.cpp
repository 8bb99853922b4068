#include "mirage/render/oit.h"

namespace mirage::render {

const char* toString(OitMode m) { return nameOf(kOitModeNames, m); }

Result<OitMode> parseOitMode(std::string_view text) { return parseNamed(text, "--oit", kOitModeNames); }

OitStats oitStats(const shaderio::OitCounters& c, uint32_t nodeCapacity) {
  OitStats s;
  s.fragments = c.nodes + c.capDropped;
  s.poolOverflow = c.nodes > nodeCapacity ? c.nodes - nodeCapacity : 0;
  s.capDropped = c.capDropped;
  s.layersDropped = c.layersDropped;
  s.coveredPixels = c.coveredPixels;
  uint64_t squares = uint64_t(c.squaredLayersHi) << 32 | c.squaredLayersLo;
  s.msl = c.coveredPixels ? double(squares) / c.coveredPixels : 0.0;
  return s;
}

} // namespace mirage::render
