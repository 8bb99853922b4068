#pragma once
// The static files of the browser client, served on the stream server's port (transport.h).
#include <filesystem>
#include <string>

#include "transport_ws.h"

namespace mirage::stream {

// GET or HEAD of `target` inside `dir` (staticFilePath): 200 with the file, 403 for a target outside
// the directory or not a plain name, 404 for a missing file or no directory, 405 for other methods.
ws::HttpReply serveStaticFile(const std::filesystem::path& dir, const std::string& method, const std::string& target);

} // namespace mirage::stream
