#pragma once
// Streaming file reader for the text and binary parsers: a large buffer refilled from the file with read(2), so huge
// files are parsed without holding a second full copy in memory. Not public API.
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mirage::io::detail {

class ChunkReader {
public:
  explicit ChunkReader(size_t chunkSize = size_t(16) << 20) : chunkSize_(chunkSize) {}
  ~ChunkReader() {
    if (fd_ >= 0) ::close(fd_);
  }
  ChunkReader(const ChunkReader&) = delete;
  ChunkReader& operator=(const ChunkReader&) = delete;

  bool open(const std::filesystem::path& path) {
    fd_ = ::open(path.c_str(), O_RDONLY);
    if (fd_ < 0) return false;
    ::posix_fadvise(fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
    // A small file gets a buffer its size, not the whole chunk: the buffer is zeroed and faulted in
    // on allocation, which dominated the import of small files (fuzzing imports thousands).
    size_t size = chunkSize_;
    struct stat st {};
    if (::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode) && size_t(st.st_size) < size)
      size = std::max<size_t>(size_t(st.st_size) + 1, 4096);
    buf_.resize(size);
    return true;
  }

  // Make at least n bytes available at data(); false when the file ends first (data() then holds the rest).
  bool ensure(size_t n) {
    if (end_ - pos_ >= n) return true;
    if (pos_ > 0) { // compact: keep the unread tail at the front
      std::memmove(buf_.data(), buf_.data() + pos_, end_ - pos_);
      base_ += pos_;
      end_ -= pos_;
      pos_ = 0;
    }
    if (n > buf_.size()) buf_.resize(n);
    while (end_ < n && !eof_) {
      ssize_t got = ::read(fd_, buf_.data() + end_, buf_.size() - end_);
      if (got <= 0) {
        eof_ = true;
        break;
      }
      end_ += size_t(got);
    }
    return end_ - pos_ >= n;
  }
  // Bytes buffered right now (at least what the last successful ensure asked for).
  size_t available() const { return end_ - pos_; }
  // Fill as much of the buffer as the file allows; returns available().
  size_t fill() {
    ensure(buf_.size());
    return available();
  }
  const char* data() const { return buf_.data() + pos_; }
  void consume(size_t n) { pos_ += n; }
  bool atEnd() { return !ensure(1); }
  // Text formats: skip whitespace first (a trailing newline is not data). Binary formats: atEnd().
  bool atEndAfterSpace(bool text) {
    if (!text) return atEnd();
    while (ensure(1)) {
      char c = buf_[pos_];
      if (c != ' ' && c != '\t' && c != '\n' && c != '\r') return false;
      ++pos_;
    }
    return true;
  }
  // File offset of data().
  size_t offset() const { return base_ + pos_; }
  size_t capacity() const { return buf_.size(); }

  // Next whitespace-separated token (text formats); false at end of file. Tokens longer than the buffer fail.
  bool token(std::string_view& out) {
    for (;;) { // skip whitespace
      if (pos_ == end_ && !ensure(1)) return false;
      char c = buf_[pos_];
      if (c != ' ' && c != '\t' && c != '\n' && c != '\r') break;
      ++pos_;
    }
    size_t i = pos_;
    for (;;) {
      if (i == end_) {
        size_t have = i - pos_;
        bool more = ensure(have + 1); // may compact the buffer: recompute i either way
        i = pos_ + have;
        if (!more) break; // token ends at end of file
        continue;
      }
      char c = buf_[i];
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') break;
      ++i;
    }
    out = std::string_view(buf_.data() + pos_, i - pos_);
    pos_ = i;
    return true;
  }

private:
  size_t chunkSize_;
  std::vector<char> buf_;
  size_t pos_ = 0, end_ = 0;
  size_t base_ = 0; // file offset of buf_[0]
  int fd_ = -1;
  bool eof_ = false;
};

} // namespace mirage::io::detail
