#pragma once
// What the glTF importer does to the file before tinygltf parses it (not public API).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::io::detail {

// Checks and rewrites a glTF/GLB before tinygltf parses it. Checks: an empty or truncated GLB; buffer sizes against
// their data URIs, external files and the GLB BIN chunk; every bufferView inside its buffer; external buffer and
// (when checkImages) image files exist and are regular files. Then, when the file uses EXT_meshopt_compression,
// decodes every compressed bufferView (meshoptimizer 0.18 codecs and filters, after checking the extension's
// constraints on mode, byteStride, count and filter) and returns an equivalent plain GLB in memory: one BIN buffer
// holding the original buffers plus the decoded views, bufferViews rewritten to point into it, the extension
// removed (tinygltf rejects the data-less fallback buffer the extension relies on). Returns nullopt when the file
// needs no rewriting or its JSON does not parse (tinygltf then reports why).
Result<std::optional<std::vector<uint8_t>>> prepareGltf(const std::vector<char>& bytes,
                                                        const std::filesystem::path& baseDir, bool checkImages,
                                                        const std::string& file);

} // namespace mirage::io::detail
