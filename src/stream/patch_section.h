#pragma once
// A Frame's patch section (docs/stream.md, "Patch section"): removed ids, patch entries and colours
// in varints, positions as grid residuals, as is or in one zstd frame. protocol.cpp calls these for
// the Frame message.
#include "wire.h"

namespace mirage::stream::wire {

// Codec byte, byte count and the section's bytes (compressed as frame.patchCodec says).
void writePatchSection(Writer& w, const Frame& frame);
// Reads what writePatchSection wrote into frame.patchCodec, removed, updated and colours. Errors name
// the field ("updated[3].blockLog2 ...").
bool readPatchSection(Reader& r, Frame& frame, const DecodeLimits& limits);

} // namespace mirage::stream::wire
