// AssetStreamWriter: chunks written to the temp file as they are added, the table reserved after the
// header and written last with the header, then fsync, check and rename as AssetWriter does.
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <xxhash.h>
#include <zstd.h>

#include "codec.h"
#include "mirage/asset/container.h"

namespace mirage::asset {

namespace {

std::string errnoText(int err) { return std::strerror(err); }

struct Xxh3 { // a streaming XXH3-64 (the same value as detail::hash64 of all the bytes at once)
  Xxh3() : state(XXH3_createState()) { XXH3_64bits_reset(state); }
  ~Xxh3() { XXH3_freeState(state); }
  Xxh3(const Xxh3&) = delete;
  Xxh3& operator=(const Xxh3&) = delete;
  void reset() { XXH3_64bits_reset(state); }
  void add(const void* p, size_t n) { XXH3_64bits_update(state, p, n); }
  uint64_t digest() const { return XXH3_64bits_digest(state); }
  XXH3_state_t* state;
};

bool readAll(int fd, void* p, size_t n) {
  auto* bytes = static_cast<uint8_t*>(p);
  while (n > 0) {
    ssize_t r = ::read(fd, bytes, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    bytes += r;
    n -= size_t(r);
  }
  return true;
}

} // namespace

uint64_t AssetStreamWriter::payloadStart(uint32_t maxChunks) {
  return detail::alignUp(sizeof(FileHeader)) + uint64_t(maxChunks) * sizeof(ChunkEntry);
}

Result<AssetStreamWriter> AssetStreamWriter::open(const std::string& path, const std::string& temp, bool resumable,
                                                  uint32_t maxChunks) {
  if (maxChunks > kMaxChunks) return makeError(path, "too many chunks (" + std::to_string(maxChunks) + ")");
  AssetStreamWriter w;
  w.path_ = path;
  w.maxChunks_ = maxChunks;
  w.tmp_ = temp;
  w.resumable_ = resumable;
  ::unlink(w.tmp_.c_str()); // a stale temp of ours (same pid, earlier crash), or an earlier partial write
  if (!resumable) w.tmpGuard_ = TempFileGuard(w.tmp_);
  w.fd_ = ::open(w.tmp_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (w.fd_ < 0) return makeError(path, "cannot create " + w.tmp_ + ": " + errnoText(errno));
  // Header and the reserved table are written by finish(); the first payload follows them.
  w.at_ = 0;
  if (Status s = w.padTo(payloadStart(maxChunks)); !s) return s.error();
  w.marked_ = w.at_;
  return w;
}

Result<AssetStreamWriter> AssetStreamWriter::create(const std::string& path, uint32_t maxChunks) {
  return open(path, path + ".tmp-" + std::to_string(::getpid()), false, maxChunks);
}

Result<AssetStreamWriter> AssetStreamWriter::createResumable(const std::string& path, const std::string& partial,
                                                             uint32_t maxChunks) {
  return open(path, partial, true, maxChunks);
}

Result<AssetStreamWriter> AssetStreamWriter::resume(const std::string& path, const std::string& partial,
                                                    uint32_t maxChunks, std::span<const ChunkEntry> table,
                                                    uint64_t end) {
  if (maxChunks > kMaxChunks) return makeError(path, "too many chunks (" + std::to_string(maxChunks) + ")");
  if (table.size() > maxChunks || end < payloadStart(maxChunks))
    return makeError(partial, "cannot be continued: its chunks do not fit the reserved table");
  AssetStreamWriter w;
  w.path_ = path;
  w.maxChunks_ = maxChunks;
  w.tmp_ = partial;
  w.resumable_ = true;
  w.fd_ = ::open(w.tmp_.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC);
  if (w.fd_ < 0) return makeError(partial, "cannot continue the partial output: " + errnoText(errno));
  struct stat st {};
  if (::fstat(w.fd_, &st) != 0 || uint64_t(st.st_size) < end)
    return makeError(partial, "shorter than its record (" + std::to_string(end) + " bytes)");
  // The header and table region back to zeros (a write killed in finish() may have written them).
  std::vector<uint8_t> zeros(size_t(payloadStart(maxChunks)));
  if (::ftruncate(w.fd_, off_t(end)) != 0 || ::pwrite(w.fd_, zeros.data(), zeros.size(), 0) != ssize_t(zeros.size()) ||
      ::lseek(w.fd_, off_t(end), SEEK_SET) < 0)
    return makeError(partial, "cannot continue the partial output: " + errnoText(errno));
  w.table_.assign(table.begin(), table.end());
  for (const ChunkEntry& e : table) w.anyBlocked_ = w.anyBlocked_ || (e.flags & kChunkBlocked);
  w.at_ = w.marked_ = end;
  return w;
}

Result<FileMark> AssetStreamWriter::checkpoint() {
  if (error_) return *error_;
  if (fd_ < 0) return failed("written already").error();
  auto mark = markFile(fd_, tmp_, marked_, at_);
  if (!mark) {
    error_ = mark.error();
    return *error_;
  }
  marked_ = at_;
  return mark;
}

AssetStreamWriter::AssetStreamWriter(AssetStreamWriter&& o) noexcept { *this = std::move(o); }

AssetStreamWriter& AssetStreamWriter::operator=(AssetStreamWriter&& o) noexcept {
  if (this == &o) return *this;
  if (fd_ >= 0) {
    ::close(fd_);
    if (!resumable_) ::unlink(tmp_.c_str());
  }
  path_ = std::move(o.path_), tmp_ = std::move(o.tmp_);
  tmpGuard_ = std::move(o.tmpGuard_);
  fd_ = std::exchange(o.fd_, -1);
  resumable_ = o.resumable_;
  maxChunks_ = o.maxChunks_, at_ = o.at_, marked_ = o.marked_;
  table_ = std::move(o.table_);
  anyBlocked_ = o.anyBlocked_;
  error_ = std::move(o.error_);
  return *this;
}

AssetStreamWriter::~AssetStreamWriter() {
  if (fd_ < 0) return;
  ::close(fd_);
  if (!resumable_) ::unlink(tmp_.c_str());
}

Status AssetStreamWriter::failed(const std::string& problem) {
  if (!error_) error_ = makeError(path_, problem);
  return *error_;
}

Status AssetStreamWriter::padTo(uint64_t offset) {
  static const uint8_t zeros[4096] = {};
  while (at_ < offset) {
    size_t n = size_t(std::min<uint64_t>(offset - at_, sizeof zeros));
    if (!detail::writeAll(fd_, zeros, n)) return failed("write failed: " + errnoText(errno));
    at_ += n;
  }
  return Ok{};
}

Status AssetStreamWriter::append(const ChunkInfo& info, std::span<const uint8_t> stored) {
  if (error_) return *error_;
  if (fd_ < 0) return failed("written already");
  if (table_.size() >= maxChunks_) return failed("more chunks than the " + std::to_string(maxChunks_) + " reserved");
  if (Status s = padTo(detail::alignUp(at_)); !s) return s;
  table_.push_back(detail::chunkEntry(info, at_));
  anyBlocked_ = anyBlocked_ || info.blocked;
  if (!detail::writeAll(fd_, stored.data(), stored.size())) return failed("write failed: " + errnoText(errno));
  at_ += stored.size();
  return Ok{};
}

Status AssetStreamWriter::addChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel) {
  if (error_) return *error_;
  auto chunk = storeChunk(type, data, zstdLevel);
  if (!chunk) return failed(chunk.error().message);
  return append(chunk->info, chunk->stored);
}

Status AssetStreamWriter::addStoredChunk(const StoredChunk& chunk) { return append(chunk.info, chunk.stored); }

Status AssetStreamWriter::addBlockedChunk(FourCC type, std::span<const uint8_t> payload, int zstdLevel) {
  if (error_) return *error_;
  auto table = decodeBlockTable(payload, "chunk " + type.str());
  if (!table) return failed(table.error().message);
  if (table->payloadBytes != payload.size())
    return failed("chunk " + type.str() + ": blocked payload is " + std::to_string(payload.size()) +
                  " bytes, its index says " + std::to_string(table->payloadBytes));
  ChunkInfo info;
  info.type = type;
  info.blocked = true;
  info.storedBytes = payload.size();
  info.rawBytes = table->rawBytes;
  info.indexBytes = table->indexBytes;
  info.storedHash = detail::hash64(payload.first(size_t(table->indexBytes)));
  info.zstdLevel = std::clamp(zstdLevel, 0, ZSTD_maxCLevel());
  return append(info, payload);
}

Status AssetStreamWriter::addChunkFromFile(FourCC type, const std::string& rawPath, int zstdLevel) {
  if (error_) return *error_;
  if (table_.size() >= maxChunks_) return failed("more chunks than the " + std::to_string(maxChunks_) + " reserved");
  int in = ::open(rawPath.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) return failed("cannot read " + rawPath + ": " + errnoText(errno));
  struct stat st {};
  if (::fstat(in, &st) != 0) return ::close(in), failed("cannot read " + rawPath + ": " + errnoText(errno));
  uint64_t rawBytes = uint64_t(st.st_size);
  if (Status s = padTo(detail::alignUp(at_)); !s) return ::close(in), s;
  uint64_t start = at_;
  ChunkInfo info;
  info.type = type;
  info.rawBytes = rawBytes;
  std::vector<uint8_t> inBuf(1u << 20), outBuf(ZSTD_CStreamOutSize());
  Xxh3 rawHash, storedHash;
  bool ok = true;
  int level = std::clamp(zstdLevel, ZSTD_minCLevel(), ZSTD_maxCLevel());
  if (zstdLevel != 0 && rawBytes > 0) { // one frame declaring its content size, as compressFrame makes
    ZSTD_CCtx* cctx = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
    if (rawBytes >= (8u << 20))
      ZSTD_CCtx_setParameter(cctx, ZSTD_c_nbWorkers,
                             int(std::min(8u, std::max(1u, std::thread::hardware_concurrency()))));
    ZSTD_CCtx_setPledgedSrcSize(cctx, rawBytes);
    uint64_t left = rawBytes;
    while (ok) {
      size_t n = size_t(std::min<uint64_t>(left, inBuf.size()));
      if (n && !readAll(in, inBuf.data(), n)) {
        ok = false;
        break;
      }
      rawHash.add(inBuf.data(), n);
      left -= n;
      ZSTD_EndDirective mode = left == 0 ? ZSTD_e_end : ZSTD_e_continue;
      ZSTD_inBuffer input{inBuf.data(), n, 0};
      size_t remaining = 0;
      do {
        ZSTD_outBuffer output{outBuf.data(), outBuf.size(), 0};
        remaining = ZSTD_compressStream2(cctx, &output, &input, mode);
        if (ZSTD_isError(remaining) || !detail::writeAll(fd_, outBuf.data(), output.pos)) {
          ok = false;
          break;
        }
        storedHash.add(outBuf.data(), output.pos);
        at_ += output.pos;
      } while (mode == ZSTD_e_end ? remaining != 0 : input.pos < input.size);
      if (mode == ZSTD_e_end) break;
    }
    ZSTD_freeCCtx(cctx);
    if (!ok) return ::close(in), failed("chunk " + type.str() + ": cannot compress " + rawPath);
    info.compressed = at_ - start < rawBytes;
    info.zstdLevel = level;
  }
  if (!info.compressed) { // stored raw (level 0, or compression did not help): copy the file
    if (::ftruncate(fd_, off_t(start)) != 0 || ::lseek(fd_, off_t(start), SEEK_SET) < 0 || ::lseek(in, 0, SEEK_SET) < 0)
      return ::close(in), failed("write failed: " + errnoText(errno));
    at_ = start;
    rawHash.reset();
    for (uint64_t left = rawBytes; left > 0;) {
      size_t n = size_t(std::min<uint64_t>(left, inBuf.size()));
      if (!readAll(in, inBuf.data(), n) || !detail::writeAll(fd_, inBuf.data(), n))
        return ::close(in), failed("chunk " + type.str() + ": cannot copy " + rawPath);
      rawHash.add(inBuf.data(), n);
      at_ += n, left -= n;
    }
    info.zstdLevel = 0;
  }
  ::close(in);
  info.storedBytes = at_ - start;
  info.rawHash = rawHash.digest();
  info.storedHash = info.compressed ? storedHash.digest() : info.rawHash;
  table_.push_back(detail::chunkEntry(info, start));
  return Ok{};
}

Status AssetStreamWriter::finish(const std::function<Status(const std::string& tempPath)>& check) {
  if (error_) return *error_;
  if (fd_ < 0) return failed("written already");
  FileHeader header = detail::fileHeader(table_, anyBlocked_, at_);
  if (::pwrite(fd_, &header, sizeof header, 0) != ssize_t(sizeof header) ||
      ::pwrite(fd_, table_.data(), table_.size() * sizeof(ChunkEntry), off_t(header.tableOffset)) !=
          ssize_t(table_.size() * sizeof(ChunkEntry)))
    return failed("write failed: " + errnoText(errno));
  // fsync before rename: otherwise a crash can leave the new name pointing at an empty file.
  if (::fsync(fd_) != 0) return failed("fsync failed: " + errnoText(errno));
  int closed = ::close(fd_);
  fd_ = -1;
  if (closed != 0) {
    ::unlink(tmp_.c_str());
    return failed("close failed: " + errnoText(errno));
  }
  if (check)
    if (Status s = check(tmp_); !s) {
      ::unlink(tmp_.c_str());
      error_ = s.error();
      return s;
    }
  if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
    int err = errno;
    ::unlink(tmp_.c_str());
    return failed("cannot rename " + tmp_ + " to the output: " + errnoText(err));
  }
  tmpGuard_.release();
  detail::syncParentDir(path_);
  return Ok{};
}

} // namespace mirage::asset
