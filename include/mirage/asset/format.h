#pragma once
// The on-disk structs of a .mrg file (version 2) and of a blocked chunk payload, written once here
// and static_assert'ed so the layout in docs/asset.md cannot drift. All fields are little-endian.
// Tools that need to patch a file (tests that craft corrupt tables) use these rather than
// hard-coded offsets.
#include <cstddef>
#include <cstdint>

namespace mirage::asset {

inline constexpr char kMagic[8] = {'M', 'I', 'R', 'A', 'G', 'E', '\0', '\0'};
// Bumped on any change an older reader would misread. Version 2 gave chunk flag bit 1 (blocked
// payloads) and the entry's last field (indexBytes) a meaning; a version-1 file is a version-2 file
// without blocked chunks, so readers accept kMinFormatVersion..kFormatVersion, and the writer writes
// the lowest version that describes its file (1 when no chunk is blocked).
inline constexpr uint32_t kFormatVersion = 2;
inline constexpr uint32_t kMinFormatVersion = 1;
inline constexpr uint32_t kFirstBlockedVersion = 2;
// Chunk payloads start at multiples of this, so a reader may map a chunk and use it as float/uint32
// arrays (or hand it to the GPU) without copying.
inline constexpr uint64_t kPayloadAlignment = 16;
// Sanity limits checked before anything is allocated.
inline constexpr uint32_t kMaxChunks = 1u << 16;
inline constexpr uint64_t kMaxChunkBytes = uint64_t(1) << 36; // 64 GiB uncompressed per chunk

// Chunk flag bits; all other bits must be zero.
inline constexpr uint32_t kChunkZstd = 1u << 0;    // payload is one zstd frame; otherwise stored raw
inline constexpr uint32_t kChunkBlocked = 1u << 1; // payload is a block index and blocks (version 2)

struct FileHeader {
  char magic[8];        // kMagic
  uint32_t version;     // kFormatVersion
  uint32_t headerBytes; // sizeof(FileHeader): lets a future version grow the header
  uint32_t chunkCount;  // entries in the chunk table
  uint32_t flags;       // reserved, 0
  uint64_t tableOffset; // byte offset of the chunk table (16-aligned, after the header)
  uint64_t fileBytes;   // total file size: detects truncation and appended bytes directly
  uint64_t tableHash;   // XXH3_64bits of the chunk table bytes
  uint64_t reserved;    // 0
  uint64_t headerHash;  // XXH3_64bits of the bytes before this field
};
static_assert(sizeof(FileHeader) == 64);
static_assert(offsetof(FileHeader, version) == 8 && offsetof(FileHeader, tableOffset) == 24);
static_assert(offsetof(FileHeader, headerHash) == 56);

struct ChunkEntry {
  uint32_t type;        // FourCC, first character in the low byte (reads as text in a hex dump)
  uint32_t flags;       // kChunkZstd, kChunkBlocked or 0
  uint64_t offset;      // payload offset in the file, multiple of kPayloadAlignment
  uint64_t storedBytes; // payload size in the file (compressed size when kChunkZstd)
  uint64_t rawBytes;    // size after decompression (== storedBytes when stored raw; blocked: the
                        // blocks' raw bytes summed)
  uint64_t storedHash;  // XXH3_64bits of the stored payload, checked before decompressing; blocked:
                        // of its first indexBytes bytes only (what a reader reads up front)
  uint64_t rawHash;     // XXH3_64bits of the decompressed bytes: catches codec or size bugs; blocked: 0
                        // (every block carries its own checksums)
  int32_t zstdLevel;    // level the writer used (0 when stored raw); informational
  uint32_t reserved0;   // 0
  uint64_t indexBytes;  // blocked: size of the block index at the payload's start; otherwise 0
                        // (version 1: reserved, 0)
};
static_assert(sizeof(ChunkEntry) == 64);
static_assert(offsetof(ChunkEntry, offset) == 8 && offsetof(ChunkEntry, rawHash) == 40);
static_assert(offsetof(ChunkEntry, zstdLevel) == 48 && offsetof(ChunkEntry, indexBytes) == 56);

// A blocked chunk payload (blocks.h; docs/asset.md, "Blocked chunks"): a BlockIndexHeader, blockCount
// BlockEntry records, headerBytes bytes of the owner's header (all three together: the index), then
// the blocks back to back in entry order, each one zstd frame or stored raw.
inline constexpr uint32_t kBlockMagic = 0x4b4c424du; // "MBLK" (first character in the low byte)
inline constexpr uint32_t kBlockIndexVersion = 1;
inline constexpr uint32_t kBlockZstd = 1u << 0; // block flag: one zstd frame; otherwise stored raw
// Sanity limits checked before anything is allocated: blocks are pages (kilobytes to a few MB).
inline constexpr uint32_t kMaxBlocks = 1u << 24;
inline constexpr uint32_t kMaxBlockBytes = 1u << 26;       // 64 MiB uncompressed per block
inline constexpr uint32_t kMaxBlockHeaderBytes = 1u << 20; // the owner's header

struct BlockIndexHeader {
  uint32_t magic;        // kBlockMagic
  uint32_t version;      // kBlockIndexVersion
  uint32_t blockCount;   // entries after this header
  uint32_t headerBytes;  // owner's header bytes after the entries
  uint64_t payloadBytes; // index + every block: the whole chunk payload
  uint64_t indexHash;    // XXH3_64bits of the index without these 8 bytes (header, entries, owner header)
};
static_assert(sizeof(BlockIndexHeader) == 32);
static_assert(offsetof(BlockIndexHeader, payloadBytes) == 16 && offsetof(BlockIndexHeader, indexHash) == 24);

struct BlockEntry {
  uint64_t offset;      // from the start of the payload; block 0 right after the index, then back to back
  uint32_t storedBytes; // bytes in the payload (compressed size when kBlockZstd)
  uint32_t rawBytes;    // bytes after decompression (== storedBytes when stored raw), <= kMaxBlockBytes
  uint64_t storedHash;  // XXH3_64bits of the stored bytes: checked before decompressing
  uint64_t rawHash;     // XXH3_64bits of the decompressed bytes
  uint32_t flags;       // kBlockZstd or 0
  uint32_t reserved;    // 0
};
static_assert(sizeof(BlockEntry) == 40);
static_assert(offsetof(BlockEntry, storedHash) == 16 && offsetof(BlockEntry, flags) == 32);

} // namespace mirage::asset
