#pragma once
// zstd frames and XXH3 as every part of the container uses them (chunks and blocks), written once.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/asset/container.h"
#include "mirage/core/result.h"

namespace mirage::asset::detail {

// "%016x" of a checksum, for messages.
std::string hex(uint64_t v);
uint64_t hash64(std::span<const uint8_t> bytes);

// One zstd frame that declares its content size (the readers check it). Inputs of 8 MiB and more
// use zstd's worker threads, since on one thread compression would dominate a bake's write time.
Result<std::vector<uint8_t>> compressFrame(std::span<const uint8_t> data, int level);

// Decompresses `stored`, which must be exactly one zstd frame declaring `rawBytes`, into `out`
// (resized to rawBytes only after the frame's declared size matched). Returns "" or the problem.
std::string decompressFrame(std::span<const uint8_t> stored, uint64_t rawBytes, std::vector<uint8_t>& out);

// The file layout both writers share (AssetWriter, AssetStreamWriter): payloads at multiples of
// kPayloadAlignment, a chunk's table entry from its info, the header over the finished table.
inline uint64_t alignUp(uint64_t v) { return (v + kPayloadAlignment - 1) / kPayloadAlignment * kPayloadAlignment; }
ChunkEntry chunkEntry(const ChunkInfo& c, uint64_t offset);
FileHeader fileHeader(std::span<const ChunkEntry> table, bool anyBlocked, uint64_t fileBytes);
// write(2) until done (it may write less than asked); false with errno set on failure.
bool writeAll(int fd, const void* p, size_t n);
// fsync of the directory holding `path` (persists a rename; best effort).
void syncParentDir(const std::string& path);

} // namespace mirage::asset::detail
