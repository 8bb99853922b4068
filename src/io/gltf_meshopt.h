#pragma once
// EXT_meshopt_compression support for the glTF importer (not public API).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::io::detail {

// When the glTF/GLB in `bytes` uses EXT_meshopt_compression, decode every compressed bufferView (meshoptimizer
// 0.18 codecs and filters) and return an equivalent plain GLB in memory: one BIN buffer holding the original
// buffers plus the decoded views, bufferViews rewritten to point into it, the extension removed. This runs before
// tinygltf sees the file because tinygltf rejects the data-less fallback buffer the extension relies on.
// Returns nullopt when the file does not use the extension (or is not parseable: tinygltf then reports why).
Result<std::optional<std::vector<uint8_t>>>
decodeMeshoptGltf(const std::vector<char>& bytes, const std::filesystem::path& baseDir, const std::string& file);

} // namespace mirage::io::detail
