#pragma once
// A Frame's patch section (docs/stream.md, "Patch section"): removed ids, patch entries and colours
// in varints, positions as grid residuals, as is or in one zstd frame; and the particle section
// (particle_section.cpp, "Particle section"), framed alike. protocol.cpp calls these for the Frame
// message.
#include "wire.h"

namespace mirage::stream::wire {

// Codec byte, byte count and the section's bytes (compressed as frame.patchCodec says).
void writePatchSection(Writer& w, const Frame& frame);
// Reads what writePatchSection wrote into frame.patchCodec, removed, updated and colours. Errors name
// the field ("updated[3].blockLog2 ...").
bool readPatchSection(Reader& r, Frame& frame, const DecodeLimits& limits);

// The same for the particle section (frame.particleCodec, looks, particles).
void writeParticleSection(Writer& w, const Frame& frame);
bool readParticleSection(Reader& r, Frame& frame, const DecodeLimits& limits);

// A section's framing, shared by both: codec byte, u32 byte count, the raw bytes or one zstd frame
// stating its content size (at most limits.maxPatchSectionBytes either way). `name` prefixes the
// errors' fields; `content` views the raw section (in `storage` when decompressed).
void writeSection(Writer& w, PatchCodec codec, std::vector<uint8_t> raw);
bool readSectionContent(Reader& r, const std::string& name, PatchCodec& codec, std::vector<uint8_t>& storage,
                        std::span<const uint8_t>& content, const DecodeLimits& limits);
// The bytes writeSection's payload takes.
size_t sectionBytes(PatchCodec codec, std::vector<uint8_t> raw);

} // namespace mirage::stream::wire
