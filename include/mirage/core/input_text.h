#pragma once
// Two pieces every reader's error messages share, so each condition has one wording everywhere:
// why a path cannot be read as an input file, and how bytes taken from an input appear inside a message.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "mirage/core/result.h"

namespace mirage {

// Why `path` cannot be opened as an input file, or "" when it is a regular file. One phrase per condition:
// "file not found", "is a directory, not a regular file", "is a FIFO (named pipe), not a regular file",
// "is a device, not a regular file", "is a socket, not a regular file", "permission denied", or the system's
// reason. Checked before anything opens the path, so a FIFO is never opened (which would wait for a writer).
std::string inputFileProblem(const std::filesystem::path& path);

// The whole of a small text input (a material or effect file): its bytes, or one line naming the
// path and the problem (inputFileProblem's wording; "N bytes, more than a `what` may hold (maxBytes)").
Result<std::string> readInputText(const std::filesystem::path& path, uint64_t maxBytes, std::string_view what);

// Bytes from an input (file contents, names, a third-party parser's message) as they may appear in a one-line
// message: printable ASCII and well-formed printable UTF-8 kept, every other byte (newlines and other control
// characters, DEL, C1 controls, invalid UTF-8) written as \xHH, a backslash as "\\", and input past maxBytes
// elided with "...".
std::string escapeInput(std::string_view raw, size_t maxBytes);

// escapeInput in single quotes, for a name or token inside a sentence: "bad number '1.2.3'".
std::string quoteInput(std::string_view raw, size_t maxBytes = 48);

} // namespace mirage
