#pragma once
// What the streaming bake (stream_bake.cpp) and its resume check (stream_resume.cpp) share: the
// file's chunk count, a mesh's record as bytes, and its statistics decoded.
#include <cstdint>
#include <span>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "mirage/lod/stream_bake.h"

namespace mirage::lod {

// Chunks of a streamed file: one per mesh, the source map, the scene, META (the reserved table).
inline uint32_t streamChunkCount(uint32_t meshCount) { return meshCount + 3; }

// A mesh's record (kStreamRecordVersion): every field of StreamMeshRecord, byte for byte.
std::vector<uint8_t> encodeStreamRecord(const StreamMeshRecord& record);

// A mesh's statistics (its META entry, meshStatsJson) from CBOR; discarded when the bytes are not
// one CBOR value, nest deeper than kMaxStatsDepth or announce more elements than they hold. The
// limits keep damaged bytes (a journal's record) from recursing nlohmann's CBOR reader off the
// stack or making it throw (it throws on an array or object size above max_size(), whatever
// allow_exceptions says).
inline constexpr uint32_t kMaxStatsDepth = 16; // the statistics nest 3 deep
nlohmann::json decodeStats(std::span<const uint8_t> cbor);

} // namespace mirage::lod
