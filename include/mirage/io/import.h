#pragma once
// Scene import: glTF 2.0 (.gltf/.glb, incl. EXT_meshopt_compression and KHR_mesh_quantization), Wavefront OBJ+MTL
// and PLY (ascii, binary little/big endian; faces and triangle strips). Every importer returns a Scene whose meshes
// are validated (indices in range, every attribute finite) and have normals and bounds, whose materials (finite
// factors) list is never empty and whose instances (finite, in float range) place every mesh; or a one-line Error
// "<file>: <problem>" naming the input. Files the scene names (buffers, images, MTL files) must exist and decode.
// Nothing here throws. Policy and wording: docs/io.md.
#include <filesystem>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

struct ImportOptions {
  bool weld = true;              // weld vertices bit-equal in position and all attributes (see weldMesh)
  bool loadTextures = true;      // decode images to RGBA8; when false images are neither read nor required and
                                 // materials keep no texture references
  bool allowPointClouds = false; // accept meshes with points and no triangles (a scanner's PLY) instead of failing
};

// Dispatch by extension (case-insensitive): .gltf .glb .obj .ply.
Result<Scene> importScene(const std::filesystem::path& path, const ImportOptions& options = {});

Result<Scene> importGltf(const std::filesystem::path& path, const ImportOptions& options = {});
Result<Scene> importObj(const std::filesystem::path& path, const ImportOptions& options = {});
Result<Scene> importPly(const std::filesystem::path& path, const ImportOptions& options = {});

} // namespace mirage::io
