// AssetReader: validate the whole structure at open, payloads at readChunk. Every size read from
// the file is checked against the file size (or kMaxChunkBytes) before it is used to allocate,
// and all offset arithmetic is done in uint64_t after overflow checks.
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <new>
#include <cstdio>
#include <numeric>
#include <utility>

#include <xxhash.h>

#include "codec.h"
#include "mirage/asset/container.h"
#include "mirage/core/input_text.h"

namespace mirage::asset {
namespace {

using detail::hex;

// Exactly n bytes at offset; false when the source cannot give them (open() checked the ranges
// against the size, so that means an I/O or network error, or a file that shrank).
bool readAt(const ByteSource& source, uint64_t offset, void* out, size_t n) {
  return source.read(offset, out, n).empty();
}

// A blocked chunk's index from the payload's first bytes: the chunk checksum over exactly
// indexBytes, the index's own checks, and sizes agreeing with the chunk entry.
Result<BlockTable> checkedIndex(const ChunkInfo& c, std::span<const uint8_t> start, const std::string& context) {
  uint64_t hash = detail::hash64(start.first(size_t(c.indexBytes)));
  if (hash != c.storedHash)
    return makeError(context,
                     "block index checksum mismatch (stored " + hex(c.storedHash) + ", computed " + hex(hash) + ")");
  Result<BlockTable> table = decodeBlockTable(start, context);
  if (!table) return table.error();
  if (table->payloadBytes != c.storedBytes || table->indexBytes != c.indexBytes || table->rawBytes != c.rawBytes)
    return makeError(context, "block index disagrees with the chunk table on its sizes");
  return table;
}

} // namespace

std::string FourCC::str() const {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    auto c = static_cast<unsigned char>(code >> (8 * i));
    if (c >= 0x20 && c < 0x7f) {
      s += char(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02x", c);
      s += buf;
    }
  }
  return "'" + s + "'";
}

AssetReader::AssetReader(AssetReader&&) noexcept = default;
AssetReader& AssetReader::operator=(AssetReader&&) noexcept = default;
AssetReader::~AssetReader() = default;

SourceStats AssetReader::sourceStats() const { return source_ ? source_->stats() : SourceStats{}; }

Result<AssetReader> AssetReader::open(const std::string& path, const SourceOptions& options) {
  Result<std::unique_ptr<ByteSource>> source = openByteSource(path, options);
  if (!source) return source.error();
  AssetReader r;
  r.path_ = isUrl(path) ? escapeInput(path, 200) : path;
  r.source_ = std::move(*source);
  r.fileBytes_ = r.source_->size();

  // Magic first, so any non-Mirage file gets the plainest possible message.
  FileHeader h{};
  if (r.fileBytes_ < sizeof(kMagic) || !readAt(*r.source_, 0, h.magic, sizeof(kMagic)) ||
      std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0)
    return r.error("not a Mirage asset (bad magic)");
  // Version before the checksum: another version may lay the header out differently, and
  // "version 2, this build reads 1" is the useful message for a newer file.
  if (r.fileBytes_ < offsetof(FileHeader, headerBytes) || !readAt(*r.source_, 8, &h.version, sizeof(h.version)))
    return r.error("truncated header (" + std::to_string(r.fileBytes_) + " bytes)");
  if (h.version < kMinFormatVersion || h.version > kFormatVersion)
    return r.error("unsupported .mrg format version " + std::to_string(h.version) + " (this build reads versions " +
                   std::to_string(kMinFormatVersion) + " to " + std::to_string(kFormatVersion) +
                   (h.version > kFormatVersion ? "; read it with a newer mirage, or rebuild it with this one's "
                                                 "mirage build)"
                                               : "; rebuild it with mirage build)"));
  r.version_ = h.version;
  if (r.fileBytes_ < sizeof(FileHeader) || !readAt(*r.source_, 0, &h, sizeof(h)))
    return r.error("truncated header (" + std::to_string(r.fileBytes_) + " bytes, need " +
                   std::to_string(sizeof(FileHeader)) + ")");
  uint64_t headerHash = XXH3_64bits(&h, offsetof(FileHeader, headerHash));
  if (headerHash != h.headerHash)
    return r.error("header checksum mismatch (stored " + hex(h.headerHash) + ", computed " + hex(headerHash) + ")");
  // The checksum only proves the header is what some writer wrote; the fields must still make sense.
  if (h.headerBytes != sizeof(FileHeader))
    return r.error("header size " + std::to_string(h.headerBytes) + " is not " + std::to_string(sizeof(FileHeader)));
  if (h.flags != 0 || h.reserved != 0) return r.error("reserved header fields are not zero");
  if (h.fileBytes != r.fileBytes_)
    return r.error("file is " + std::to_string(r.fileBytes_) + " bytes but the header says " +
                   std::to_string(h.fileBytes) + (r.fileBytes_ < h.fileBytes ? " (truncated)" : " (trailing bytes)"));
  if (h.chunkCount > kMaxChunks)
    return r.error("chunk count " + std::to_string(h.chunkCount) + " exceeds " + std::to_string(kMaxChunks));
  if (h.tableOffset < sizeof(FileHeader) || h.tableOffset % kPayloadAlignment != 0 || h.tableOffset > r.fileBytes_)
    return r.error("chunk table offset " + std::to_string(h.tableOffset) + " is invalid");
  // chunkCount <= 2^16, so the table size cannot overflow; its end is compared without adding.
  uint64_t tableBytes = uint64_t(h.chunkCount) * sizeof(ChunkEntry);
  if (tableBytes > r.fileBytes_ - h.tableOffset)
    return r.error("chunk table (" + std::to_string(h.chunkCount) + " entries) runs past the end of the file");
  uint64_t tableEnd = h.tableOffset + tableBytes;

  std::vector<ChunkEntry> table(h.chunkCount);
  if (!readAt(*r.source_, h.tableOffset, table.data(), tableBytes)) return r.error("cannot read the chunk table");
  uint64_t tableHash = XXH3_64bits(table.data(), tableBytes);
  if (tableHash != h.tableHash)
    return r.error("chunk table checksum mismatch (stored " + hex(h.tableHash) + ", computed " + hex(tableHash) + ")");

  r.chunks_.reserve(table.size());
  for (size_t i = 0; i < table.size(); ++i) {
    const ChunkEntry& e = table[i];
    std::string name = "chunk " + std::to_string(i) + " " + FourCC(e.type).str();
    // Version 1 knows no blocked chunks: its readers saw bit 1 as unknown and indexBytes as reserved.
    uint32_t knownFlags = kChunkZstd | (h.version >= kFirstBlockedVersion ? kChunkBlocked : 0u);
    if (e.flags & ~knownFlags) return r.error(name + " has unknown flags " + hex(e.flags));
    bool blocked = e.flags & kChunkBlocked;
    if (e.reserved0 != 0 || (!blocked && e.indexBytes != 0)) return r.error(name + " has non-zero reserved fields");
    if (e.offset % kPayloadAlignment != 0)
      return r.error(name + " offset " + std::to_string(e.offset) + " is unaligned");
    if (e.offset < tableEnd)
      return r.error(name + " offset " + std::to_string(e.offset) + " overlaps the header/table");
    // Written as a subtraction so a huge storedBytes cannot wrap offset + storedBytes around.
    if (e.offset > r.fileBytes_ || e.storedBytes > r.fileBytes_ - e.offset)
      return r.error(name + " (offset " + std::to_string(e.offset) + ", " + std::to_string(e.storedBytes) +
                     " bytes) runs past the end of the file (" + std::to_string(r.fileBytes_) + " bytes)");
    if (e.rawBytes > kMaxChunkBytes)
      return r.error(name + " claims " + std::to_string(e.rawBytes) + " uncompressed bytes, over the limit of " +
                     std::to_string(kMaxChunkBytes));
    bool compressed = e.flags & kChunkZstd;
    if (blocked && (compressed || e.rawHash != 0))
      return r.error(name + " is blocked but also marked compressed or has a checksum of its raw bytes");
    // The index is at least its fixed header and lies inside the payload; its own checks run when read.
    if (blocked && (e.indexBytes < sizeof(BlockIndexHeader) || e.indexBytes > e.storedBytes))
      return r.error(name + " block index of " + std::to_string(e.indexBytes) + " bytes does not fit its " +
                     std::to_string(e.storedBytes) + "-byte payload");
    if (!compressed && !blocked && (e.rawBytes != e.storedBytes || e.zstdLevel != 0))
      return r.error(name + " is stored raw but its sizes differ or it names a zstd level");
    // A zstd frame has a header of at least a few bytes, and the writer only keeps it if smaller.
    if (compressed && (e.storedBytes == 0 || e.storedBytes >= e.rawBytes))
      return r.error(name + " is marked compressed but its sizes are inconsistent");
    ChunkInfo c;
    c.type = FourCC(e.type);
    c.compressed = compressed;
    c.blocked = blocked;
    c.indexBytes = e.indexBytes;
    c.offset = e.offset;
    c.storedBytes = e.storedBytes;
    c.rawBytes = e.rawBytes;
    c.storedHash = e.storedHash;
    c.rawHash = e.rawHash;
    c.zstdLevel = e.zstdLevel;
    r.chunks_.push_back(c);
  }
  // Overlapping payloads would let one corrupt write damage two chunks; a valid writer never makes them.
  std::vector<size_t> order(r.chunks_.size());
  std::iota(order.begin(), order.end(), size_t(0));
  // Ties broken by size: an empty chunk shares its offset with the next payload, and must sort first.
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const ChunkInfo &x = r.chunks_[a], &y = r.chunks_[b];
    return x.offset != y.offset ? x.offset < y.offset : x.storedBytes < y.storedBytes;
  });
  for (size_t k = 1; k < order.size(); ++k) {
    const ChunkInfo& prev = r.chunks_[order[k - 1]];
    const ChunkInfo& cur = r.chunks_[order[k]];
    if (cur.offset < prev.offset + prev.storedBytes) // no overflow: both inside the file
      return r.error("chunks " + std::to_string(std::min(order[k - 1], order[k])) + " and " +
                     std::to_string(std::max(order[k - 1], order[k])) + " overlap");
  }
  return r;
}

std::optional<size_t> AssetReader::find(FourCC type) const {
  for (size_t i = 0; i < chunks_.size(); ++i)
    if (chunks_[i].type == type) return i;
  return std::nullopt;
}

Result<std::vector<uint8_t>> AssetReader::readChunk(FourCC type) const {
  std::optional<size_t> i = find(type);
  if (!i) return error("no " + type.str() + " chunk");
  return readChunk(*i);
}

std::string AssetReader::chunkContext(size_t index) const {
  // Appended piecewise: GCC 12 warns falsely (-Wrestrict) on `" " + string`.
  std::string context = path_;
  context += ": chunk ";
  context += std::to_string(index);
  if (index < chunks_.size()) {
    context += ' ';
    context += chunks_[index].type.str();
  }
  return context;
}

Result<std::vector<uint8_t>> AssetReader::readStoredChunk(size_t index) const {
  if (index >= chunks_.size())
    return error("chunk index " + std::to_string(index) + " out of range (" + std::to_string(chunks_.size()) +
                 " chunks)");
  const ChunkInfo& c = chunks_[index];
  std::string name = "chunk " + std::to_string(index) + " " + c.type.str();
  try {
    // storedBytes was checked against the file size in open(), so this allocation is bounded.
    std::vector<uint8_t> stored(c.storedBytes);
    if (!readAt(*source_, c.offset, stored.data(), stored.size()))
      return error(name + ": read failed (file changed since it was opened?)");
    // A blocked chunk's checksum covers its index; the index then vouches for each block.
    if (c.blocked) {
      Result<BlockTable> table = checkedIndex(c, stored, chunkContext(index));
      if (!table) return table.error();
      for (size_t b = 0; b < table->blocks.size(); ++b) {
        const BlockInfo& info = table->blocks[b];
        std::span<const uint8_t> bytes = std::span(stored).subspan(size_t(info.offset), size_t(info.storedBytes));
        if (Status s = checkStoredBlock(*table, b, bytes, chunkContext(index)); !s) return s.error();
      }
      return stored;
    }
    uint64_t storedHash = detail::hash64(stored);
    if (storedHash != c.storedHash)
      return error(name + " checksum mismatch (stored " + hex(c.storedHash) + ", computed " + hex(storedHash) + ")");
    return stored;
  } catch (const std::bad_alloc&) {
    return error(name + ": out of memory for " + std::to_string(c.storedBytes) + " bytes");
  }
}

Result<BlockTable> AssetReader::readBlockTable(size_t index) const {
  if (index >= chunks_.size())
    return error("chunk index " + std::to_string(index) + " out of range (" + std::to_string(chunks_.size()) +
                 " chunks)");
  const ChunkInfo& c = chunks_[index];
  std::string name = "chunk " + std::to_string(index) + " " + c.type.str();
  if (!c.blocked) return error(name + " is not blocked (read it whole with readChunk)");
  try {
    // indexBytes <= storedBytes was checked in open(): the read stays inside the file.
    std::vector<uint8_t> bytes(c.indexBytes);
    if (!readAt(*source_, c.offset, bytes.data(), bytes.size()))
      return error(name + ": read failed (file changed since it was opened?)");
    Result<BlockTable> table = checkedIndex(c, bytes, chunkContext(index));
    if (!table) return table.error();
    return table;
  } catch (const std::bad_alloc&) {
    return error(name + ": out of memory for " + std::to_string(c.indexBytes) + " bytes");
  }
}

Result<std::vector<uint8_t>> AssetReader::readBlock(size_t index, const BlockTable& table, size_t block) const {
  if (index >= chunks_.size() || !chunks_[index].blocked)
    return error("chunk index " + std::to_string(index) + " is not a blocked chunk");
  const ChunkInfo& c = chunks_[index];
  if (block >= table.blocks.size())
    return makeError(chunkContext(index), "block " + std::to_string(block) + " out of range (" +
                                              std::to_string(table.blocks.size()) + " blocks)");
  const BlockInfo& b = table.blocks[block];
  // The table came from readBlockTable, so the block lies inside this chunk's payload; checked
  // again since a caller may pass any table.
  if (b.offset > c.storedBytes || b.storedBytes > c.storedBytes - b.offset)
    return makeError(chunkContext(index), "block " + std::to_string(block) + " lies outside the chunk");
  try {
    std::vector<uint8_t> stored(b.storedBytes);
    if (!readAt(*source_, c.offset + b.offset, stored.data(), stored.size()))
      return makeError(chunkContext(index), "block " + std::to_string(block) +
                                                ": read failed (file changed since it "
                                                "was opened?)");
    return decodeBlock(table, block, stored, chunkContext(index));
  } catch (const std::bad_alloc&) {
    return makeError(chunkContext(index), "block " + std::to_string(block) + ": out of memory");
  }
}

Result<std::vector<uint8_t>> AssetReader::readChunk(size_t index) const {
  Result<std::vector<uint8_t>> read = readStoredChunk(index);
  if (!read) return read.error();
  const ChunkInfo& c = chunks_[index];
  if (c.blocked) return read; // checked block by block; decodeBlocks decompresses
  std::string name = "chunk " + std::to_string(index) + " " + c.type.str();
  try {
    std::vector<uint8_t> stored = std::move(*read);
    std::vector<uint8_t> raw;
    if (!c.compressed) {
      raw = std::move(stored);
    } else if (std::string problem = detail::decompressFrame(stored, c.rawBytes, raw); !problem.empty()) {
      return error(name + ": " + problem);
    }
    uint64_t rawHash = detail::hash64(raw);
    if (rawHash != c.rawHash)
      return error(name + " uncompressed checksum mismatch (stored " + hex(c.rawHash) + ", computed " + hex(rawHash) +
                   ")");
    return raw;
  } catch (const std::bad_alloc&) {
    return error(name + ": out of memory for " + std::to_string(c.rawBytes) + " bytes");
  }
}

} // namespace mirage::asset
