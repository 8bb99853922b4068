#pragma once
// Surfel clouds on disk: binary PLY (x y z nx ny nz red green blue alpha radius, in progressive
// order; the quantization box and N_ref spacing ride in comments) and the .mrg 'SURF' chunk, stored
// as blocks in prefix order so that any byte prefix decodes to a surfel prefix (docs/surfels.md,
// "The 'SURF' chunk").
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/surfels/surfel.h"

namespace mirage::asset {
class AssetReader;
}

namespace mirage::surfels {

// Written atomically (temp file + rename): a failed write leaves nothing at `path`.
Status writeSurfelPly(const std::string& path, const SurfelCloud& cloud);
// Reads what writeSurfelPly writes (and any binary little-endian PLY with float x, y, z and
// optional normals, uchar colours and float radius). Errors are one line naming the file.
Result<SurfelCloud> readSurfelPly(const std::string& path);
// True for a PLY that writeSurfelPly wrote (its header says so): a surfel cloud, not a mesh or scan.
bool isSurfelPly(const std::string& path);

// A cloud of one mesh of a scene, in that mesh's object space (every instance of the mesh reuses it
// under its own transform), or of the whole scene in world space (mesh = kWholeScene).
constexpr uint32_t kWholeScene = UINT32_MAX;
struct MeshSurfels {
  uint32_t mesh = kWholeScene; // index into Scene::meshes
  SurfelCloud cloud;
};

// How a 'SURF' chunk is cut into blocks. Block sizes double from firstSurfels up to maxSurfels (each
// block as large as all before it, so a byte prefix cut inside a block wastes at most half of what
// arrived), then stay at maxSurfels. Both powers of two, 256 <= first <= max <= 2^20: block ends
// are then ends of the renderer's coherent blocks (docs/surfels.md) up to 16 * max surfels.
struct SurfelBlockConfig {
  uint32_t firstSurfels = 1024; // 20 KB raw: every object's coarse preview costs little bandwidth
  uint32_t maxSurfels = 16384;  // 320 KB raw: the size of a cluster page; per-block overhead < 0.1 %
  int zstdLevel = 3;            // per block (asset::kDefaultZstdLevel); 0 stores the blocks raw
};
// An error naming the sizes when a config breaks the rules above.
Status checkSurfelBlockConfig(const SurfelBlockConfig& config);
// "FIRST:MAX" (e.g. "1024:16384") with the default level, checked.
Result<SurfelBlockConfig> parseSurfelBlockConfig(const std::string& text);
// The prefix lengths at which blocks end (the last one is `count`; none for an empty cloud).
std::vector<uint32_t> surfelBlockEnds(uint32_t count, const SurfelBlockConfig& config);

// 'SURF' chunk payload, version 3: a blocked payload (asset/blocks.h) whose index header is
// SurfelChunkHeader (48 bytes), uint32 mesh, uint32 pad, and whose block b holds Surfel[n_b] then
// float radii[n_b] of the surfels in prefix order. Versions 1 and 2 (one flat array, what earlier
// builds wrote) are still read. Encoding fails only for a config checkSurfelBlockConfig rejects.
Result<std::vector<uint8_t>> encodeSurfelChunk(const SurfelCloud& cloud, uint32_t mesh = kWholeScene,
                                               const SurfelBlockConfig& config = {});
// Version 2 (header, mesh word, Surfel[count], radii[count]): what earlier builds wrote, for tests of
// old files and tools that must write them.
std::vector<uint8_t> encodeSurfelChunkFlat(const SurfelCloud& cloud, uint32_t mesh = kWholeScene);
Result<MeshSurfels> decodeSurfelChunkWithMesh(std::span<const uint8_t> bytes, const std::string& file);
Result<SurfelCloud> decodeSurfelChunk(std::span<const uint8_t> bytes, const std::string& file);

// What a byte prefix of a version-3 'SURF' payload holds: the surfels of its complete blocks, a
// prefix of the cloud (box and reference spacings are the whole cloud's), once the index arrived.
struct SurfelPrefix {
  MeshSurfels surfels;
  uint32_t total = 0;     // surfels in the whole cloud (known with the index)
  bool haveIndex = false; // the index (header and block table) is complete
  uint64_t nextBytes = 0; // prefix length that completes the index or the next block
  bool complete() const { return haveIndex && surfels.cloud.size() == total; }
};
// Any prefix of a valid payload decodes (zero surfels until the index is complete); damage in the
// index or a complete block is an error naming the block.
Result<SurfelPrefix> decodeSurfelPrefix(std::span<const uint8_t> bytes, const std::string& file);

// Chunk `index` of an open file, which must be a 'SURF' chunk; its layout (blocked or flat) must
// match its table entry. Errors name the file, the chunk and, for damage, the block.
Result<MeshSurfels> readSurfelChunk(const asset::AssetReader& reader, size_t index);
// A .mrg file holding 'SURF' chunks (the caller adds scene chunks when it has them): one for a
// whole-scene cloud, or one per mesh.
Status writeSurfelMrg(const std::string& path, const SurfelCloud& cloud, const SurfelBlockConfig& config = {});
Status writeSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds,
                      const SurfelBlockConfig& config = {});
// Replaces the SURF chunks of the .mrg at `path` by `clouds`, atomically. Every other chunk is
// copied as stored (same bytes, same compression), so appending never changes the geometry.
Status appendSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds,
                       const SurfelBlockConfig& config = {});
// The single cloud of a file (an error names the count when it holds several: use readSurfelMrgAll).
Result<SurfelCloud> readSurfelMrg(const std::string& path);
// Every 'SURF' chunk, in file order.
Result<std::vector<MeshSurfels>> readSurfelMrgAll(const std::string& path);

} // namespace mirage::surfels
