// Byte sources: local files by pread, URLs by HTTP range requests (source_http.cpp).
#include "mirage/asset/source.h"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "mirage/core/input_text.h"
#include "source_http.h"

namespace mirage::asset {
namespace {

class FileSource final : public ByteSource {
public:
  FileSource(int fd, uint64_t size) : fd_(fd), size_(size) {}
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;

  uint64_t size() const override { return size_; }
  SourceStats stats() const override { return {requests_.load(), bytes_.load()}; }

  // pread until done; the file shrinking after open ends it early.
  std::string read(uint64_t offset, void* out, size_t n) const override {
    auto* bytes = static_cast<uint8_t*>(out);
    while (n > 0) {
      ssize_t r = ::pread(fd_, bytes, n, off_t(offset));
      requests_.fetch_add(1, std::memory_order_relaxed);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) return std::strerror(errno);
      if (r == 0) return "file changed since it was opened?";
      bytes_.fetch_add(uint64_t(r), std::memory_order_relaxed);
      bytes += r;
      n -= size_t(r);
      offset += uint64_t(r);
    }
    return {};
  }

private:
  int fd_;
  uint64_t size_;
  mutable std::atomic<uint64_t> requests_{0}, bytes_{0};
};

Result<std::unique_ptr<ByteSource>> openFile(const std::string& path) {
  if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(path, problem);
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer forever. It has no
  // effect on regular files, and anything else is rejected right below.
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return makeError(path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    std::string problem = std::strerror(errno);
    ::close(fd);
    return makeError(path, problem);
  }
  // Directories and devices have no meaningful size; reading them would fail later or block.
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return makeError(path, "not a regular file");
  }
  return std::unique_ptr<ByteSource>(new FileSource(fd, uint64_t(st.st_size)));
}

} // namespace

bool isUrl(std::string_view s) {
  auto startsWithNoCase = [&](std::string_view prefix) {
    if (s.size() < prefix.size()) return false;
    for (size_t i = 0; i < prefix.size(); ++i)
      if (std::tolower(static_cast<unsigned char>(s[i])) != prefix[i]) return false;
    return true;
  };
  return startsWithNoCase("http://") || startsWithNoCase("https://");
}

Result<std::unique_ptr<ByteSource>> openByteSource(const std::string& pathOrUrl, const SourceOptions& options) {
  if (isUrl(pathOrUrl)) return detail::openHttp(pathOrUrl, options);
  return openFile(pathOrUrl);
}

} // namespace mirage::asset
