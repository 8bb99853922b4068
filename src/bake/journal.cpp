#include "mirage/bake/journal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include <xxhash.h>

#include "mirage/asset/bytes.h"

namespace mirage::bake {

namespace {

constexpr uint32_t kMagic = 0x4a47524d; // "MRGJ"
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 4 + 4 + 8 + 4;
constexpr size_t kEntryHeaderBytes = 4 + 8 + 8;

Status writeAll(int fd, const uint8_t* p, size_t n, const std::string& path) {
  while (n) {
    ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return makeError(path, std::string("cannot write the bake journal: ") + std::strerror(errno));
    p += w, n -= size_t(w);
  }
  return Ok{};
}

} // namespace

Result<JournalContents> readJournal(const std::string& path, uint64_t fingerprint, uint32_t units) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return JournalContents{};
  std::vector<uint8_t> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parseJournal(data, path, fingerprint, units);
}

Result<JournalContents> parseJournal(std::span<const uint8_t> data, const std::string& path, uint64_t fingerprint,
                                     uint32_t units) {
  JournalContents out;
  asset::ByteReader r(data, path);
  uint32_t magic = 0, version = 0, count = 0;
  uint64_t print = 0;
  r.read(magic), r.read(version), r.read(print), r.read(count);
  if (!r.ok() || magic != kMagic || version != kVersion) return makeError(path, "not a bake journal of this version");
  if (print != fingerprint || count != units)
    return makeError(path, "journal of another bake (other inputs or settings): remove it or bake without --resume");
  out.validBytes = kHeaderBytes;
  std::vector<bool> seen(units);
  while (r.remaining() >= kEntryHeaderBytes) {
    uint32_t unit = 0;
    uint64_t length = 0, hash = 0;
    r.read(unit), r.read(length), r.read(hash);
    if (length > r.remaining()) break; // torn: the process died while writing it
    std::span<const uint8_t> bytes(data.data() + r.position(), length);
    if (unit >= units || XXH3_64bits(bytes.data(), bytes.size()) != hash)
      return makeError(path, "damaged bake journal (entry at byte " + std::to_string(out.validBytes) +
                                 "): remove it and bake again");
    r.skip(length);
    out.validBytes = r.position();
    if (seen[unit]) continue;
    seen[unit] = true;
    out.entries.push_back({unit, std::vector<uint8_t>(bytes.begin(), bytes.end())});
  }
  return out;
}

Result<Journal> Journal::open(const std::string& path, uint64_t fingerprint, uint32_t units, uint64_t keepBytes) {
  int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (keepBytes ? 0 : O_TRUNC);
  int fd = ::open(path.c_str(), flags, 0644);
  if (fd < 0) return makeError(path, std::string("cannot open the bake journal: ") + std::strerror(errno));
  Journal j(path, fd);
  if (keepBytes) {
    if (::ftruncate(fd, off_t(keepBytes)) != 0 || ::lseek(fd, off_t(keepBytes), SEEK_SET) < 0)
      return makeError(path, std::string("cannot continue the bake journal: ") + std::strerror(errno));
    return j;
  }
  asset::ByteWriter w;
  w.write(kMagic), w.write(kVersion), w.write(fingerprint), w.write(units);
  if (Status s = writeAll(fd, w.data().data(), w.size(), path); !s) return s.error();
  return j;
}

Journal::Journal(Journal&& other) noexcept : path_(std::move(other.path_)), fd_(other.fd_) { other.fd_ = -1; }

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

Status Journal::append(uint32_t unit, std::span<const uint8_t> bytes) {
  asset::ByteWriter w;
  w.write(unit), w.write(uint64_t(bytes.size())), w.write(uint64_t(XXH3_64bits(bytes.data(), bytes.size())));
  if (Status s = writeAll(fd_, w.data().data(), w.size(), path_); !s) return s;
  return writeAll(fd_, bytes.data(), bytes.size(), path_);
}

void Journal::remove() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(path_.c_str());
}

} // namespace mirage::bake
