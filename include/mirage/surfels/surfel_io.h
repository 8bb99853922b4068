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
// True for a PLY that writeSurfelPly wrote (its header says so): a surfel cloud, not a mesh or scan.
bool isSurfelPly(const std::string& path);

// A cloud of one mesh of a scene, in that mesh's object space (every instance of the mesh reuses it
// under its own transform), or of the whole scene in world space (mesh = kWholeScene).
constexpr uint32_t kWholeScene = UINT32_MAX;
struct MeshSurfels {
  uint32_t mesh = kWholeScene; // index into Scene::meshes
  SurfelCloud cloud;
};

// 'SURF' chunk payload, version 2: SurfelChunkHeader (48 bytes), uint32 mesh, uint32 pad,
// Surfel[count], float radii[count]. Version 1 (no mesh word: a whole-scene cloud) is still read.
std::vector<uint8_t> encodeSurfelChunk(const SurfelCloud& cloud, uint32_t mesh = kWholeScene);
Result<MeshSurfels> decodeSurfelChunkWithMesh(std::span<const uint8_t> bytes, const std::string& file);
Result<SurfelCloud> decodeSurfelChunk(std::span<const uint8_t> bytes, const std::string& file);
// A .mrg file holding 'SURF' chunks (the caller adds scene chunks when it has them): one for a
// whole-scene cloud, or one per mesh.
Status writeSurfelMrg(const std::string& path, const SurfelCloud& cloud);
Status writeSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds);
// Replaces the SURF chunks of the .mrg at `path` by `clouds`, atomically. Every other chunk is
// copied as stored (same bytes, same compression), so appending never changes the geometry.
Status appendSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds);
// The single cloud of a file (an error names the count when it holds several: use readSurfelMrgAll).
Result<SurfelCloud> readSurfelMrg(const std::string& path);
// Every 'SURF' chunk, in file order.
Result<std::vector<MeshSurfels>> readSurfelMrgAll(const std::string& path);

} // namespace mirage::surfels
