#pragma once
// Blocked chunk payloads: an index (block table + the owner's header) followed by independently
// compressed blocks, each with its own checksums, so a reader reads the index once and then any
// block by its byte range (pread, or an HTTP range request) without reading or checksumming the
// rest. A block is opaque bytes; the chunk's owner (SURF surfel prefixes, cluster-DAG pages) gives
// them a meaning. Byte layout: format.h (BlockIndexHeader, BlockEntry); contract and checks:
// docs/asset.md, "Blocked chunks". AssetWriter::addBlockedChunk stores a payload made here;
// AssetReader::readBlockTable / readBlock read it from a file.
//
// Errors are one line, `<context>: <problem>`, where context names the file and chunk (the
// AssetReader passes "<file>: chunk 3 'SURF'") and the problem names the block.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/asset/format.h"
#include "mirage/core/result.h"

namespace mirage::asset {

// One block as the index describes it (offsets from the start of the payload).
struct BlockInfo {
  uint64_t offset = 0;
  uint64_t storedBytes = 0;
  uint64_t rawBytes = 0;
  uint64_t storedHash = 0; // XXH3_64bits of the stored bytes
  uint64_t rawHash = 0;    // XXH3_64bits of the decompressed bytes
  bool compressed = false; // one zstd frame; otherwise stored raw
};

// The index of a blocked payload, validated: blocks back to back from indexBytes to payloadBytes.
struct BlockTable {
  std::vector<uint8_t> header;   // the owner's bytes stored in the index (covered by its checksum)
  std::vector<BlockInfo> blocks; // in payload order
  uint64_t indexBytes = 0;       // bytes before block 0: what a reader fetches up front
  uint64_t payloadBytes = 0;     // index + every block
  uint64_t rawBytes = 0;         // the blocks' decompressed sizes summed
};

// One block ready to be assembled: its stored bytes and their description (offset left 0).
struct EncodedBlock {
  BlockInfo info;
  std::vector<uint8_t> stored;
};

// Compresses one block with zstd at `zstdLevel` (0: stored raw; stored raw too when compression
// does not make it smaller). Independent of the other blocks: a writer may encode blocks in
// parallel. Fails only for a block over kMaxBlockBytes or when zstd fails.
Result<EncodedBlock> encodeBlock(std::span<const uint8_t> raw, int zstdLevel);
// The payload: index (BlockIndexHeader, entries, `header`) then the blocks in order.
Result<std::vector<uint8_t>> assembleBlocks(std::span<const uint8_t> header, std::span<const EncodedBlock> blocks);
// encodeBlock on each block, then assembleBlocks.
Result<std::vector<uint8_t>> encodeBlocks(std::span<const uint8_t> header,
                                          std::span<const std::span<const uint8_t>> blocks, int zstdLevel);

// The size of the index that a payload starting with `start` declares, after checking its magic,
// version and limits: a reader that knows nothing else fetches sizeof(BlockIndexHeader) bytes, then
// this many. An error when `start` is shorter than BlockIndexHeader.
Result<uint64_t> blockIndexBytes(std::span<const uint8_t> start, const std::string& context);
// The index from the payload's first bytes (at least the index; anything after it is ignored):
// index checksum, limits, entries (flags, sizes, blocks back to back up to payloadBytes).
Result<BlockTable> decodeBlockTable(std::span<const uint8_t> start, const std::string& context);
// Block `block`'s stored bytes against its stored checksum (no decompression).
Status checkStoredBlock(const BlockTable& table, size_t block, std::span<const uint8_t> stored,
                        const std::string& context);
// Block `block`'s decompressed bytes from exactly its stored bytes (payload[offset, offset +
// storedBytes)): stored checksum, zstd frame size, exactly one frame, raw size, raw checksum.
Result<std::vector<uint8_t>> decodeBlock(const BlockTable& table, size_t block, std::span<const uint8_t> stored,
                                         const std::string& context);

// What a byte prefix of a payload holds: the index once it is complete, and the longest run of
// complete blocks from block 0, each verified and decompressed.
struct BlockPrefix {
  bool haveIndex = false;
  BlockTable table;                      // valid when haveIndex
  std::vector<std::vector<uint8_t>> raw; // blocks 0..raw.size()-1, decompressed
  uint64_t usedBytes = 0;                // prefix bytes those cover (index + complete blocks)
  uint64_t nextBytes = 0;                // prefix length that completes the index or the next block
  bool complete() const { return haveIndex && raw.size() == table.blocks.size(); }
};
// Any prefix of a valid payload (down to zero bytes) decodes without error; a damaged index or a
// damaged *complete* block is an error naming it (an incomplete last block is not looked at), and
// so are bytes beyond payloadBytes.
Result<BlockPrefix> decodeBlockPrefix(std::span<const uint8_t> prefix, const std::string& context);
// The whole payload: every block, exactly payloadBytes bytes (a short payload is "truncated").
Result<BlockPrefix> decodeBlocks(std::span<const uint8_t> payload, const std::string& context);

} // namespace mirage::asset
