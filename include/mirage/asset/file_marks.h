#pragma once
// Checkpoints of a file written front to back (a streaming .mrg, the spool beside it), so that a
// later process can check what an earlier one wrote and continue the file after that one died (the
// streaming bake's --resume, docs/bake.md "Journal and --resume"). A mark says how far the file was
// whole and durable, and the XXH3 of its bytes since the previous mark: back-to-back ranges, so a
// check reads each byte once and names the first range that differs.
#include <cstdint>
#include <span>
#include <string>

#include "mirage/core/result.h"

namespace mirage::asset {

struct FileMark {
  uint64_t end = 0;  // the file's length at the mark
  uint64_t hash = 0; // XXH3-64 of its bytes from the previous mark's end (or the first range's start)
};

// fdatasync(fd) (the bytes are durable before anyone records the mark), then the mark of the bytes
// [begin, end) of the file open at `fd` (readable too), read back (just written: from the page
// cache). Errors name `path`.
Result<FileMark> markFile(int fd, const std::string& path, uint64_t begin, uint64_t end);

// The number of `marks` (ranges back to back from `begin`) that the file at `path` holds as marked:
// marks.size() when all match; less when a range's bytes differ or the file ends before its end.
// Errors: the file cannot be read.
Result<size_t> matchingFileMarks(const std::string& path, uint64_t begin, std::span<const FileMark> marks);

} // namespace mirage::asset
