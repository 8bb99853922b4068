// AssetWriter: compress chunks as they are added, then lay out header, table and aligned payloads
// and write them through a temp file that is fsynced and renamed into place.
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <new>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <zstd.h>

#include "codec.h"
#include "mirage/core/temp_files.h"
#include "mirage/asset/container.h"

namespace mirage::asset {
namespace {

std::string errnoText(int err) { return std::strerror(err); }

} // namespace

namespace detail {

bool writeAll(int fd, const void* p, size_t n) {
  const auto* bytes = static_cast<const uint8_t*>(p);
  while (n > 0) {
    ssize_t w = ::write(fd, bytes, n);
    if (w < 0 && errno == EINTR) continue;
    if (w == 0) errno = EIO; // no progress and no errno: report an I/O error, not a stale errno
    if (w <= 0) return false;
    bytes += w;
    n -= size_t(w);
  }
  return true;
}

void syncParentDir(const std::string& path) {
  size_t slash = path.find_last_of('/');
  std::string dirPath = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  int dir = ::open(dirPath.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

ChunkEntry chunkEntry(const ChunkInfo& c, uint64_t offset) {
  ChunkEntry e{};
  e.type = c.type.code;
  e.flags = c.blocked ? kChunkBlocked : c.compressed ? kChunkZstd : 0;
  e.offset = offset;
  e.storedBytes = c.storedBytes;
  e.rawBytes = c.rawBytes;
  e.storedHash = c.storedHash;
  e.rawHash = c.rawHash;
  e.zstdLevel = c.zstdLevel;
  e.indexBytes = c.blocked ? c.indexBytes : 0;
  return e;
}

FileHeader fileHeader(std::span<const ChunkEntry> table, bool anyBlocked, uint64_t fileBytes) {
  FileHeader header{};
  std::memcpy(header.magic, kMagic, sizeof(kMagic));
  // The lowest version that describes the file: without blocked chunks, older readers read it too.
  header.version = anyBlocked ? kFirstBlockedVersion : kMinFormatVersion;
  header.headerBytes = sizeof(FileHeader);
  header.chunkCount = uint32_t(table.size());
  header.tableOffset = alignUp(sizeof(FileHeader));
  header.fileBytes = fileBytes;
  header.tableHash = hash64(std::span(reinterpret_cast<const uint8_t*>(table.data()), table.size_bytes()));
  header.headerHash = hash64(std::span(reinterpret_cast<const uint8_t*>(&header), offsetof(FileHeader, headerHash)));
  return header;
}

} // namespace detail

Result<StoredChunk> storeChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel) {
  try {
    StoredChunk p;
    p.info.type = type;
    p.info.rawBytes = data.size();
    p.info.rawHash = detail::hash64(data);
    if (zstdLevel != 0 && !data.empty()) {
      int level = std::clamp(zstdLevel, ZSTD_minCLevel(), ZSTD_maxCLevel());
      Result<std::vector<uint8_t>> packed = detail::compressFrame(data, level);
      if (!packed) return Error{"chunk " + type.str() + ": " + packed.error().message};
      // Stored raw when compression does not help: the reader then skips decompression entirely.
      if (packed->size() < data.size()) {
        p.stored = std::move(*packed);
        p.info.compressed = true;
        p.info.zstdLevel = level;
      }
    }
    if (!p.info.compressed) p.stored.assign(data.begin(), data.end());
    p.info.storedBytes = p.stored.size();
    p.info.storedHash = detail::hash64(p.stored);
    return p;
  } catch (const std::bad_alloc&) {
    return Error{"chunk " + type.str() + ": out of memory (" + std::to_string(data.size()) + " bytes)"};
  }
}

void AssetWriter::addChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel) {
  if (error_) return;
  Result<StoredChunk> p = storeChunk(type, data, zstdLevel);
  if (!p) {
    error_ = p.error();
    return;
  }
  chunks_.push_back(Pending{p->info, std::move(p->stored)});
}

void AssetWriter::addStoredChunk(const ChunkInfo& info, std::vector<uint8_t> stored) {
  if (error_) return;
  // A blocked chunk's checksum covers its index (its blocks carry their own).
  uint64_t hashed = info.blocked ? info.indexBytes : info.storedBytes;
  if (stored.size() != info.storedBytes || hashed > stored.size() ||
      detail::hash64(std::span(stored).first(size_t(hashed))) != info.storedHash) {
    error_ = Error{"chunk " + info.type.str() + ": stored bytes do not match their table entry"};
    return;
  }
  Pending p;
  p.info = info;
  p.info.offset = 0; // laid out again by write()
  p.stored = std::move(stored);
  chunks_.push_back(std::move(p));
}

void AssetWriter::addBlockedChunk(FourCC type, std::vector<uint8_t> payload, int zstdLevel) {
  if (error_) return;
  Result<BlockTable> table = decodeBlockTable(payload, "chunk " + type.str());
  if (!table) {
    error_ = table.error();
    return;
  }
  Pending p;
  p.info.type = type;
  p.info.blocked = true;
  p.info.storedBytes = payload.size();
  p.info.rawBytes = table->rawBytes;
  p.info.indexBytes = table->indexBytes;
  p.info.storedHash = detail::hash64(std::span(payload).first(size_t(table->indexBytes)));
  p.info.zstdLevel = std::clamp(zstdLevel, 0, ZSTD_maxCLevel());
  if (table->payloadBytes != payload.size()) {
    error_ = Error{"chunk " + type.str() + ": blocked payload is " + std::to_string(payload.size()) +
                   " bytes, its index says " + std::to_string(table->payloadBytes)};
    return;
  }
  p.stored = std::move(payload);
  chunks_.push_back(std::move(p));
}

Status AssetWriter::write(const std::string& path,
                          const std::function<Status(const std::string& tempPath)>& check) const {
  if (error_) return makeError(path, error_->message);
  if (chunks_.size() > kMaxChunks) return makeError(path, "too many chunks (" + std::to_string(chunks_.size()) + ")");

  // Layout: header, table, then each payload at the next aligned offset (zero padding between).
  bool anyBlocked = std::any_of(chunks_.begin(), chunks_.end(), [](const Pending& p) { return p.info.blocked; });
  std::vector<ChunkEntry> table(chunks_.size());
  uint64_t end = detail::alignUp(sizeof(FileHeader)) + table.size() * sizeof(ChunkEntry);
  for (size_t i = 0; i < chunks_.size(); ++i) {
    table[i] = detail::chunkEntry(chunks_[i].info, detail::alignUp(end));
    end = table[i].offset + table[i].storedBytes;
  }
  FileHeader header = detail::fileHeader(table, anyBlocked, end);

  // O_EXCL | O_NOFOLLOW: never write through a symlink or into a file someone else created under
  // the temp name. A stale temp of ours (same pid, earlier crash) is removed first.
  std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  ::unlink(tmp.c_str());
  TempFileGuard guard(tmp); // removed if a signal stops the process before the rename
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) return makeError(path, "cannot create " + tmp + ": " + errnoText(errno));

  auto fail = [&](const std::string& problem) -> Status {
    int err = errno;
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    return makeError(path, problem + ": " + errnoText(err));
  };

  static const uint8_t zeros[kPayloadAlignment] = {};
  uint64_t at = 0;
  auto pad = [&](uint64_t to) { // zero padding up to an aligned offset
    bool ok = detail::writeAll(fd, zeros, size_t(to - at));
    at = to;
    return ok;
  };
  if (!detail::writeAll(fd, &header, sizeof(header))) return fail("write failed");
  at = sizeof(header);
  if (!pad(header.tableOffset) || !detail::writeAll(fd, table.data(), table.size() * sizeof(ChunkEntry)))
    return fail("write failed");
  at += table.size() * sizeof(ChunkEntry);
  for (size_t i = 0; i < chunks_.size(); ++i) {
    if (!pad(table[i].offset) || !detail::writeAll(fd, chunks_[i].stored.data(), chunks_[i].stored.size()))
      return fail("write failed");
    at += chunks_[i].stored.size();
  }
  // fsync before rename: otherwise a crash can leave the new name pointing at an empty file.
  if (::fsync(fd) != 0) return fail("fsync failed");
  int closeResult = ::close(fd);
  fd = -1;
  if (closeResult != 0) return fail("close failed");
  if (check) {
    if (Status s = check(tmp); !s) {
      ::unlink(tmp.c_str());
      return s;
    }
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) return fail("cannot rename " + tmp + " to the output");
  // Persist the rename itself; best effort (some file systems refuse fsync on directories).
  detail::syncParentDir(path);
  return Ok{};
}

} // namespace mirage::asset
