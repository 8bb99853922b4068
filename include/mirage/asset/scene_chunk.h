#pragma once
// Scene <-> 'SCEN' chunk payload, and .mrg files holding one scene. Geometry is stored plainly
// (float arrays, uint32 indices); the compact cluster encoding belongs to the LOD module's 'CDAG'.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::asset {

// Version of the SCEN payload layout, independent of the container version, so the scene
// encoding can evolve without touching other chunks. 2 added the material file's fields (origin,
// shading model, Blinn-Phong, detail maps, per-map UV transforms) and point lights; version 1
// payloads still decode (those fields at their defaults, no lights).
inline constexpr uint32_t kSceneChunkVersion = 2;
inline constexpr uint32_t kOldestSceneChunkVersion = 1;

// Checks what a decoder must reject: triangle indices inside the vertex array, optional attribute
// arrays empty or one per vertex, material/texture/mesh indices in range, texture byte counts of
// width*height*4, enums in range, and no NaN/Inf in any float; point lights with a positive
// radius and a non-negative intensity. `file` names the scene in errors.
Status validateScene(const Scene& scene, const std::string& file);

// Encodes every field of `scene` (validate it first: decodeScene rejects what validateScene does).
std::vector<uint8_t> encodeScene(const Scene& scene);
// Decodes a SCEN payload; never reads out of bounds and allocates at most a small multiple of
// `bytes.size()`. Errors read "<fileForErrors>: SCEN: <problem>".
Result<Scene> decodeScene(std::span<const uint8_t> bytes, const std::string& fileForErrors);

// A .mrg with a 'SCEN' chunk and a 'META' JSON chunk (format versions and counts). Validates the
// scene first so it never writes a file loadScene would reject; the write is atomic.
Status saveScene(const std::string& path, const Scene& scene, int zstdLevel = 3);
// Opens a .mrg, decodes its first 'SCEN' chunk, and checks a 'META' chunk against it if present.
Result<Scene> loadScene(const std::string& path);

} // namespace mirage::asset
