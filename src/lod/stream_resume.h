#pragma once
// What the streaming bake (stream_bake.cpp) and its resume check (stream_resume.cpp) share: the
// file's chunk count and a mesh's record as bytes.
#include <cstdint>
#include <vector>

#include "mirage/lod/stream_bake.h"

namespace mirage::lod {

// Chunks of a streamed file: one per mesh, the source map, the scene, META (the reserved table).
inline uint32_t streamChunkCount(uint32_t meshCount) { return meshCount + 3; }

// A mesh's record (kStreamRecordVersion): every field of StreamMeshRecord, byte for byte.
std::vector<uint8_t> encodeStreamRecord(const StreamMeshRecord& record);

} // namespace mirage::lod
