#pragma once
// Surfel clouds on disk: binary PLY (x y z nx ny nz red green blue alpha radius, in progressive
// order; the quantization box and N_ref spacing ride in comments) and the .mrg 'SURF' chunk.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/surfels/surfel.h"

namespace mirage::surfels {

// Written atomically (temp file + rename): a failed write leaves nothing at `path`.
Status writeSurfelPly(const std::string& path, const SurfelCloud& cloud);
// Reads what writeSurfelPly writes (and any binary little-endian PLY with float x, y, z and
// optional normals, uchar colours and float radius). Errors are one line naming the file.
Result<SurfelCloud> readSurfelPly(const std::string& path);

// 'SURF' chunk payload, version 1: SurfelChunkHeader, Surfel[count], float radii[count].
std::vector<uint8_t> encodeSurfelChunk(const SurfelCloud& cloud);
Result<SurfelCloud> decodeSurfelChunk(std::span<const uint8_t> bytes, const std::string& file);
// A .mrg file holding one 'SURF' chunk (the caller adds scene chunks when it has them).
Status writeSurfelMrg(const std::string& path, const SurfelCloud& cloud);
Result<SurfelCloud> readSurfelMrg(const std::string& path);

} // namespace mirage::surfels
