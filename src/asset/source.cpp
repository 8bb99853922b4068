// Byte sources: local files by pread, URLs by HTTP range requests (source_http.cpp).
#include "mirage/asset/source.h"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <utility>

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

// A source whose reads return no sooner than a link of `bitsPerSecond` would have delivered the
// bytes received since open: the average rate stays within the limit for any pattern of reads. (libcurl's
// receive limit alone paces within a transfer; a page's range request of a few KiB ends before it
// takes effect.)
class PacedSource final : public ByteSource {
public:
  PacedSource(std::unique_ptr<ByteSource> inner, uint64_t bitsPerSecond)
      : inner_(std::move(inner)), bitsPerSecond_(bitsPerSecond) {}

  uint64_t size() const override { return inner_->size(); }
  SourceStats stats() const override { return inner_->stats(); }

  std::string read(uint64_t offset, void* out, size_t n) const override {
    std::string problem = inner_->read(offset, out, n);
    // What the source received (a URL's probe and read-ahead too), not only what was asked for.
    double due = double(inner_->stats().bytes) * 8.0 / double(bitsPerSecond_);
    std::this_thread::sleep_until(
        opened_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(due)));
    return problem;
  }

private:
  std::unique_ptr<ByteSource> inner_;
  uint64_t bitsPerSecond_;
  std::chrono::steady_clock::time_point opened_ = std::chrono::steady_clock::now();
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
  auto source = isUrl(pathOrUrl) ? detail::openHttp(pathOrUrl, options) : openFile(pathOrUrl);
  if (!source || options.bandwidthBitsPerSecond == 0) return source;
  return std::unique_ptr<ByteSource>(new PacedSource(std::move(*source), options.bandwidthBitsPerSecond));
}

Result<uint64_t> parseBandwidth(std::string_view text) {
  auto bad = [&] {
    return Error{"bandwidth " + quoteInput(text) + ": expected a rate like 500kbit, 20Mbit or 1Gbit"};
  };
  std::string s(text);
  char* end = nullptr;
  double value = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || !std::isfinite(value) || !(value > 0.0)) return bad();
  std::string unit(end);
  for (char& c : unit) c = char(std::tolower(static_cast<unsigned char>(c)));
  double scale = unit == "bit" ? 1.0 : unit == "kbit" ? 1e3 : unit == "mbit" ? 1e6 : unit == "gbit" ? 1e9 : 0.0;
  if (scale == 0.0 || value * scale < 1.0 || value * scale > 1e15) return bad();
  return uint64_t(std::llround(value * scale));
}

} // namespace mirage::asset
