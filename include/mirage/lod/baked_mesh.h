#pragma once
// A BakedMesh (lod_asset.h) as bytes, every field bit for bit: how a distributed bake carries a
// mesh's result from the process that built it to the one that writes the .mrg, and how its
// journal keeps it for a resumed bake (docs/bake.md). Not a file format of its own: only the same
// build of Mirage reads what it wrote (the journal's header checks that, src/bake/journal.cpp).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/lod/lod_asset.h"

namespace mirage::lod {

std::vector<uint8_t> encodeBakedMesh(const BakedMesh& mesh);
// `where` names the source in errors. Checks that the bytes are complete, the DAG's structure
// (checkDagStructure, linear time) and the source map's cluster ids, so that nothing read from a
// journal reaches the encoders out of range.
Result<BakedMesh> decodeBakedMesh(std::span<const uint8_t> bytes, const std::string& where);

// What bakeLodMesh reads of a scene's mesh (its name in errors, positions, normals, uvs, indices),
// as bytes sent to the process that bakes it; bakeMeshUnit bakes from them.
std::vector<uint8_t> encodeMeshUnit(const Scene& scene, size_t mesh);
Result<BakedMesh> bakeMeshUnit(std::span<const uint8_t> unit, const BuildConfig& config);

} // namespace mirage::lod
