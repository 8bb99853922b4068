#pragma once
// zstd frames and XXH3 as every part of the container uses them (chunks and blocks), written once.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

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

} // namespace mirage::asset::detail
