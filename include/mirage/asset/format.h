#pragma once
// The on-disk structs of a .mrg file (version 1), written once here and static_assert'ed so the
// layout in docs/asset.md cannot drift. All fields are little-endian. Tools that need to patch a
// file (tests that craft corrupt tables) use these rather than hard-coded offsets.
#include <cstddef>
#include <cstdint>

namespace mirage::asset {

inline constexpr char kMagic[8] = {'M', 'I', 'R', 'A', 'G', 'E', '\0', '\0'};
// Bumped on any change a version-1 reader would misread; readers accept exactly their version.
inline constexpr uint32_t kFormatVersion = 1;
// Chunk payloads start at multiples of this, so a reader may map a chunk and use it as float/uint32
// arrays (or hand it to the GPU) without copying.
inline constexpr uint64_t kPayloadAlignment = 16;
// Sanity limits checked before anything is allocated.
inline constexpr uint32_t kMaxChunks = 1u << 16;
inline constexpr uint64_t kMaxChunkBytes = uint64_t(1) << 36; // 64 GiB uncompressed per chunk

// Chunk flag bits; all other bits must be zero.
inline constexpr uint32_t kChunkZstd = 1u << 0; // payload is one zstd frame; otherwise stored raw

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
  uint32_t flags;       // kChunkZstd or 0
  uint64_t offset;      // payload offset in the file, multiple of kPayloadAlignment
  uint64_t storedBytes; // payload size in the file (compressed size when kChunkZstd)
  uint64_t rawBytes;    // size after decompression (== storedBytes when stored raw)
  uint64_t storedHash;  // XXH3_64bits of the stored payload: checked before decompressing
  uint64_t rawHash;     // XXH3_64bits of the decompressed bytes: catches codec or size bugs
  int32_t zstdLevel;    // level the writer used (0 when stored raw); informational
  uint32_t reserved0;   // 0
  uint64_t reserved1;   // 0
};
static_assert(sizeof(ChunkEntry) == 64);
static_assert(offsetof(ChunkEntry, offset) == 8 && offsetof(ChunkEntry, rawHash) == 40);
static_assert(offsetof(ChunkEntry, zstdLevel) == 48);

} // namespace mirage::asset
