#include "mirage/asset/file_marks.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include <xxhash.h>

namespace mirage::asset {

namespace {

// XXH3-64 of the bytes [begin, end) of `fd`; false when the file ends first or a read fails.
bool hashRange(int fd, uint64_t begin, uint64_t end, std::vector<uint8_t>& buffer, uint64_t& hash) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  bool ok = true;
  for (uint64_t at = begin; at < end && ok;) {
    size_t n = size_t(std::min<uint64_t>(end - at, buffer.size()));
    ssize_t r = ::pread(fd, buffer.data(), n, off_t(at));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) ok = false;
    if (!ok) break;
    XXH3_64bits_update(state, buffer.data(), size_t(r));
    at += uint64_t(r);
  }
  hash = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return ok;
}

} // namespace

Result<FileMark> markFile(int fd, const std::string& path, uint64_t begin, uint64_t end) {
  if (::fdatasync(fd) != 0) return makeError(path, std::string("fdatasync failed: ") + std::strerror(errno));
  std::vector<uint8_t> buffer(size_t(std::min<uint64_t>(end - begin, 1u << 20)));
  FileMark mark{end, 0};
  if (!hashRange(fd, begin, end, buffer, mark.hash))
    return makeError(path, std::string("cannot read back what was written: ") + std::strerror(errno));
  return mark;
}

Result<size_t> matchingFileMarks(const std::string& path, uint64_t begin, std::span<const FileMark> marks) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return makeError(path, std::string("cannot read: ") + std::strerror(errno));
  std::vector<uint8_t> buffer(1u << 20);
  size_t matching = 0;
  for (uint64_t at = begin; matching < marks.size(); ++matching) {
    uint64_t hash = 0;
    if (marks[matching].end < at || !hashRange(fd, at, marks[matching].end, buffer, hash) ||
        hash != marks[matching].hash)
      break;
    at = marks[matching].end;
  }
  ::close(fd);
  return matching;
}

} // namespace mirage::asset
