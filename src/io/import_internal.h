#pragma once
// Helpers shared by the importers (not public API).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mirage/core/input_text.h"
#include "mirage/io/import.h"

namespace mirage::io::detail {

// The file name as it appears in error messages (escaped: a name may hold any byte but a message is one line).
inline std::string displayName(const std::filesystem::path& p) { return escapeInput(p.string(), 4096); }

// Read a whole file into memory; Error when it is not a readable regular file (inputFileProblem's wording).
Result<std::vector<char>> readFile(const std::filesystem::path& path);

// Common tail of every importer: validate each mesh, weld (optional), compute missing normals, bounds; make sure
// materials is non-empty and every material index valid; give an identity instance to each mesh when the format
// has no placement (OBJ, PLY). Error "no triangles" when nothing is left.
Status finalizeScene(Scene& scene, const std::string& file, const ImportOptions& options);

// Largest texture side the importers accept (the common GPU limit for 2D images); larger ones are rejected before
// decoding, so a corrupt or hostile header cannot demand gigabytes.
constexpr uint32_t kMaxTextureSide = 16384;

// Decode image bytes (png/jpg/bmp/tga/...) to RGBA8 through stb_image; "" on success, else the problem. Every
// importer decodes through here: one limit, one wording.
std::string decodeImageProblem(const unsigned char* bytes, size_t size, Texture& out);

// Read and decode an image file; a missing or non-regular file is an Error too (inputFileProblem's wording).
Status loadImageFile(const std::filesystem::path& path, const std::string& file, const std::string& what, Texture& out);

} // namespace mirage::io::detail
