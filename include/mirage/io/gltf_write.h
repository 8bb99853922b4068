#pragma once
// Scene export as glTF 2.0 binary (.glb): one glTF mesh (one triangle primitive) per Mesh, one node
// per Instance with a column-major "matrix", metallic-roughness materials, textures embedded as PNG.
// The write is atomic (temp file + rename); errors name the file.
#include <filesystem>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

Status writeGlb(const Scene& scene, const std::filesystem::path& path);

} // namespace mirage::io
