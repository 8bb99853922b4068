// Blocked chunk payloads (blocks.h): encoding, index validation, per-block verification and the
// byte-prefix reader. Every size read from the payload is checked against the bytes there (or the
// kMax* limits) before it is used to allocate.
#include "mirage/asset/blocks.h"

#include <algorithm>
#include <cstring>
#include <new>

#include <zstd.h>

#include "codec.h"

namespace mirage::asset {
namespace {

using detail::hash64;
using detail::hex;

// The index checksum skips its own field: bytes [0, 24) and [32, indexBytes).
uint64_t indexHash(std::span<const uint8_t> index) {
  std::vector<uint8_t> copy(index.begin(), index.end());
  std::memset(copy.data() + offsetof(BlockIndexHeader, indexHash), 0, sizeof(uint64_t));
  return hash64(copy);
}

std::string blockName(size_t block) { return "block " + std::to_string(block); }

} // namespace

Result<EncodedBlock> encodeBlock(std::span<const uint8_t> raw, int zstdLevel) {
  if (raw.size() > kMaxBlockBytes)
    return Error{"block of " + std::to_string(raw.size()) + " bytes exceeds the limit of " +
                 std::to_string(kMaxBlockBytes)};
  try {
    EncodedBlock b;
    b.info.rawBytes = raw.size();
    b.info.rawHash = hash64(raw);
    if (zstdLevel != 0 && !raw.empty()) {
      Result<std::vector<uint8_t>> packed =
          detail::compressFrame(raw, std::clamp(zstdLevel, ZSTD_minCLevel(), ZSTD_maxCLevel()));
      if (!packed) return packed.error();
      // Stored raw when compression does not help: the reader then skips decompression.
      if (packed->size() < raw.size()) {
        b.stored = std::move(*packed);
        b.info.compressed = true;
      }
    }
    if (!b.info.compressed) b.stored.assign(raw.begin(), raw.end());
    b.info.storedBytes = b.stored.size();
    b.info.storedHash = hash64(b.stored);
    return b;
  } catch (const std::bad_alloc&) {
    return Error{"out of memory for a block of " + std::to_string(raw.size()) + " bytes"};
  }
}

Result<std::vector<uint8_t>> assembleBlocks(std::span<const uint8_t> header, std::span<const EncodedBlock> blocks) {
  if (blocks.size() > kMaxBlocks)
    return Error{std::to_string(blocks.size()) + " blocks exceed the limit of " + std::to_string(kMaxBlocks)};
  if (header.size() > kMaxBlockHeaderBytes)
    return Error{"block header of " + std::to_string(header.size()) + " bytes exceeds the limit of " +
                 std::to_string(kMaxBlockHeaderBytes)};
  try {
    uint64_t indexBytes = sizeof(BlockIndexHeader) + blocks.size() * sizeof(BlockEntry) + header.size();
    uint64_t end = indexBytes;
    std::vector<BlockEntry> entries(blocks.size());
    for (size_t i = 0; i < blocks.size(); ++i) {
      const BlockInfo& b = blocks[i].info;
      if (b.rawBytes > kMaxBlockBytes || b.storedBytes != blocks[i].stored.size() ||
          (!b.compressed && b.storedBytes != b.rawBytes) ||
          (b.compressed && (b.storedBytes == 0 || b.storedBytes >= b.rawBytes)))
        return Error{blockName(i) + " is inconsistent (not made by encodeBlock)"};
      entries[i] = BlockEntry{
          end, uint32_t(b.storedBytes), uint32_t(b.rawBytes), b.storedHash, b.rawHash, b.compressed ? kBlockZstd : 0u,
          0u};
      end += b.storedBytes;
    }
    BlockIndexHeader h{};
    h.magic = kBlockMagic;
    h.version = kBlockIndexVersion;
    h.blockCount = uint32_t(blocks.size());
    h.headerBytes = uint32_t(header.size());
    h.payloadBytes = end;
    std::vector<uint8_t> out(end);
    uint8_t* at = out.data();
    std::memcpy(at, &h, sizeof(h));
    at += sizeof(h);
    if (!entries.empty()) std::memcpy(at, entries.data(), entries.size() * sizeof(BlockEntry));
    at += entries.size() * sizeof(BlockEntry);
    if (!header.empty()) std::memcpy(at, header.data(), header.size());
    h.indexHash = indexHash(std::span(out).first(indexBytes));
    std::memcpy(out.data(), &h, sizeof(h));
    at = out.data() + indexBytes;
    for (const EncodedBlock& b : blocks) {
      if (!b.stored.empty()) std::memcpy(at, b.stored.data(), b.stored.size());
      at += b.stored.size();
    }
    return out;
  } catch (const std::bad_alloc&) {
    return Error{"out of memory assembling " + std::to_string(blocks.size()) + " blocks"};
  }
}

Result<std::vector<uint8_t>> encodeBlocks(std::span<const uint8_t> header,
                                          std::span<const std::span<const uint8_t>> blocks, int zstdLevel) {
  std::vector<EncodedBlock> encoded;
  encoded.reserve(blocks.size());
  for (size_t i = 0; i < blocks.size(); ++i) {
    Result<EncodedBlock> b = encodeBlock(blocks[i], zstdLevel);
    if (!b) return Error{blockName(i) + ": " + b.error().message};
    encoded.push_back(std::move(*b));
  }
  return assembleBlocks(header, encoded);
}

Result<uint64_t> blockIndexBytes(std::span<const uint8_t> start, const std::string& context) {
  if (start.size() < sizeof(BlockIndexHeader))
    return makeError(context, "block index truncated (" + std::to_string(start.size()) + " bytes, need " +
                                  std::to_string(sizeof(BlockIndexHeader)) + ")");
  BlockIndexHeader h;
  std::memcpy(&h, start.data(), sizeof(h));
  if (h.magic != kBlockMagic) return makeError(context, "not a blocked payload (bad block index magic)");
  // Version before anything else: a newer index may be laid out differently.
  if (h.version != kBlockIndexVersion)
    return makeError(context, "unsupported block index version " + std::to_string(h.version) +
                                  " (this build reads version " + std::to_string(kBlockIndexVersion) +
                                  "; rebuild the file with this build's mirage)");
  if (h.blockCount > kMaxBlocks)
    return makeError(context, "block count " + std::to_string(h.blockCount) + " exceeds " + std::to_string(kMaxBlocks));
  if (h.headerBytes > kMaxBlockHeaderBytes)
    return makeError(context, "block header of " + std::to_string(h.headerBytes) + " bytes exceeds " +
                                  std::to_string(kMaxBlockHeaderBytes));
  // Both counts are bounded, so the sum cannot overflow.
  uint64_t indexBytes = sizeof(BlockIndexHeader) + uint64_t(h.blockCount) * sizeof(BlockEntry) + h.headerBytes;
  if (indexBytes > h.payloadBytes)
    return makeError(context, "block index (" + std::to_string(indexBytes) + " bytes) is larger than its payload (" +
                                  std::to_string(h.payloadBytes) + " bytes)");
  return indexBytes;
}

Result<BlockTable> decodeBlockTable(std::span<const uint8_t> start, const std::string& context) {
  Result<uint64_t> indexBytes = blockIndexBytes(start, context);
  if (!indexBytes) return indexBytes.error();
  if (start.size() < *indexBytes)
    return makeError(context, "block index truncated (" + std::to_string(start.size()) + " of " +
                                  std::to_string(*indexBytes) + " bytes)");
  std::span<const uint8_t> index = start.first(size_t(*indexBytes));
  BlockIndexHeader h;
  std::memcpy(&h, index.data(), sizeof(h));
  // The checksum first: every offset and size below relies on it.
  uint64_t computed = indexHash(index);
  if (computed != h.indexHash)
    return makeError(context,
                     "block index checksum mismatch (stored " + hex(h.indexHash) + ", computed " + hex(computed) + ")");
  try {
    BlockTable t;
    t.indexBytes = *indexBytes;
    t.payloadBytes = h.payloadBytes;
    t.blocks.resize(h.blockCount); // bounded: the entries are in `index`
    uint64_t end = t.indexBytes;
    for (size_t i = 0; i < h.blockCount; ++i) {
      BlockEntry e;
      std::memcpy(&e, index.data() + sizeof(h) + i * sizeof(BlockEntry), sizeof(e));
      std::string name = blockName(i);
      if (e.flags & ~kBlockZstd) return makeError(context, name + " has unknown flags " + hex(e.flags));
      if (e.reserved != 0) return makeError(context, name + " has a non-zero reserved field");
      // Back to back: no gaps, no overlaps, no aliasing of the index.
      if (e.offset != end)
        return makeError(context, name + " offset " + std::to_string(e.offset) + " is not " + std::to_string(end) +
                                      " (blocks follow the index back to back)");
      if (e.storedBytes > t.payloadBytes - end) // end <= payloadBytes holds here
        return makeError(context, name + " (" + std::to_string(e.storedBytes) + " bytes at " + std::to_string(end) +
                                      ") runs past the payload (" + std::to_string(t.payloadBytes) + " bytes)");
      if (e.rawBytes > kMaxBlockBytes)
        return makeError(context, name + " claims " + std::to_string(e.rawBytes) + " bytes, over the limit of " +
                                      std::to_string(kMaxBlockBytes));
      bool compressed = e.flags & kBlockZstd;
      if (!compressed && e.storedBytes != e.rawBytes)
        return makeError(context, name + " is stored raw but its sizes differ");
      if (compressed && (e.storedBytes == 0 || e.storedBytes >= e.rawBytes))
        return makeError(context, name + " is marked compressed but its sizes are inconsistent");
      t.blocks[i] = BlockInfo{e.offset, e.storedBytes, e.rawBytes, e.storedHash, e.rawHash, compressed};
      end += e.storedBytes;
      t.rawBytes += e.rawBytes;
    }
    if (end != t.payloadBytes)
      return makeError(context, "blocks end at " + std::to_string(end) + " but the payload is " +
                                    std::to_string(t.payloadBytes) + " bytes");
    const uint8_t* header = index.data() + sizeof(h) + size_t(h.blockCount) * sizeof(BlockEntry);
    t.header.assign(header, header + h.headerBytes);
    return t;
  } catch (const std::bad_alloc&) {
    return makeError(context, "out of memory for " + std::to_string(h.blockCount) + " block entries");
  }
}

Status checkStoredBlock(const BlockTable& table, size_t block, std::span<const uint8_t> stored,
                        const std::string& context) {
  if (block >= table.blocks.size())
    return makeError(context, blockName(block) + " out of range (" + std::to_string(table.blocks.size()) + " blocks)");
  const BlockInfo& b = table.blocks[block];
  if (stored.size() != b.storedBytes)
    return makeError(context, blockName(block) + " has " + std::to_string(stored.size()) + " bytes, the index says " +
                                  std::to_string(b.storedBytes));
  uint64_t computed = hash64(stored);
  if (computed != b.storedHash)
    return makeError(context, blockName(block) + " checksum mismatch (stored " + hex(b.storedHash) + ", computed " +
                                  hex(computed) + ")");
  return Ok{};
}

Result<std::vector<uint8_t>> decodeBlock(const BlockTable& table, size_t block, std::span<const uint8_t> stored,
                                         const std::string& context) {
  if (Status s = checkStoredBlock(table, block, stored, context); !s) return s.error();
  const BlockInfo& b = table.blocks[block];
  try {
    std::vector<uint8_t> raw;
    if (!b.compressed) {
      raw.assign(stored.begin(), stored.end());
    } else if (std::string problem = detail::decompressFrame(stored, b.rawBytes, raw); !problem.empty()) {
      return makeError(context, blockName(block) + ": " + problem);
    }
    uint64_t computed = hash64(raw);
    if (computed != b.rawHash)
      return makeError(context, blockName(block) + " uncompressed checksum mismatch (stored " + hex(b.rawHash) +
                                    ", computed " + hex(computed) + ")");
    return raw;
  } catch (const std::bad_alloc&) {
    return makeError(context, blockName(block) + ": out of memory for " + std::to_string(b.rawBytes) + " bytes");
  }
}

Result<BlockPrefix> decodeBlockPrefix(std::span<const uint8_t> prefix, const std::string& context) {
  BlockPrefix p;
  p.nextBytes = sizeof(BlockIndexHeader);
  if (prefix.size() < sizeof(BlockIndexHeader)) {
    // Even a few bytes must be the start of a blocked payload.
    uint32_t magic = 0;
    size_t n = std::min(prefix.size(), sizeof(magic));
    if (n > 0) std::memcpy(&magic, prefix.data(), n);
    uint32_t mask = n == 4 ? ~0u : (1u << (8 * n)) - 1u;
    if ((magic & mask) != (kBlockMagic & mask))
      return makeError(context, "not a blocked payload (bad block index magic)");
    return p;
  }
  Result<uint64_t> indexBytes = blockIndexBytes(prefix, context);
  if (!indexBytes) return indexBytes.error();
  if (prefix.size() < *indexBytes) {
    p.nextBytes = *indexBytes;
    return p;
  }
  Result<BlockTable> table = decodeBlockTable(prefix, context);
  if (!table) return table.error();
  p.haveIndex = true;
  p.table = std::move(*table);
  if (prefix.size() > p.table.payloadBytes)
    return makeError(context, std::to_string(prefix.size() - p.table.payloadBytes) +
                                  " bytes after the last block (payload is " + std::to_string(p.table.payloadBytes) +
                                  " bytes)");
  p.usedBytes = p.table.indexBytes;
  for (size_t i = 0; i < p.table.blocks.size(); ++i) {
    const BlockInfo& b = p.table.blocks[i];
    if (b.storedBytes > prefix.size() - b.offset) break; // offset <= payloadBytes: checked with the index
    Result<std::vector<uint8_t>> raw =
        decodeBlock(p.table, i, prefix.subspan(size_t(b.offset), size_t(b.storedBytes)), context);
    if (!raw) return raw.error();
    p.raw.push_back(std::move(*raw));
    p.usedBytes = b.offset + b.storedBytes;
  }
  p.nextBytes = p.raw.size() < p.table.blocks.size()
                    ? p.table.blocks[p.raw.size()].offset + p.table.blocks[p.raw.size()].storedBytes
                    : p.table.payloadBytes;
  return p;
}

Result<BlockPrefix> decodeBlocks(std::span<const uint8_t> payload, const std::string& context) {
  Result<BlockPrefix> p = decodeBlockPrefix(payload, context);
  if (!p) return p.error();
  if (!p->complete())
    return makeError(context, "blocked payload truncated (" + std::to_string(payload.size()) + " bytes, " +
                                  (p->haveIndex ? std::to_string(p->raw.size()) + " of " +
                                                      std::to_string(p->table.blocks.size()) + " blocks complete"
                                                : std::string("index incomplete")) +
                                  ")");
  return p;
}

} // namespace mirage::asset
