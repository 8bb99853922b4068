#pragma once
// Helpers shared by the importers (not public API).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mirage/io/import.h"

namespace mirage::io::detail {

// The file name as it appears in error messages.
inline std::string displayName(const std::filesystem::path& p) { return p.string(); }

// Read a whole file into memory; Error when it cannot be opened or read.
Result<std::vector<char>> readFile(const std::filesystem::path& path);

// Common tail of every importer: validate each mesh, weld (optional), compute missing normals, bounds; make sure
// materials is non-empty and every material index valid; give an identity instance to each mesh when the format
// has no placement (OBJ, PLY). Error "no triangles" when nothing is left.
Status finalizeScene(Scene& scene, const std::string& file, const ImportOptions& options);

// Decode an image file (png/jpg/...) to RGBA8 through stb_image; false when it cannot be read or decoded.
bool loadImageFile(const std::filesystem::path& path, Texture& out);

} // namespace mirage::io::detail
