// Blocked chunks: exact round trips (bytes, file, copies between files), every byte prefix decoding
// to exactly its complete blocks, one block read without touching the others, every byte flip in a
// block rejected naming file, chunk and block (and only that block), crafted indices with valid
// checksums rejected by the structural checks, and version-1 files next to version-2 ones.
#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "asset_test_util.h"
#include "mirage/asset/blocks.h"
#include "mirage/asset/container.h"

using namespace mirage;
using namespace mirage::asset;
using namespace mirage::asset::test;

namespace {

// Blocks of every kind: empty, compressible (stored as zstd), random (stored raw), one byte.
std::vector<std::vector<uint8_t>> sampleBlocks() {
  std::mt19937 rng(7);
  std::vector<std::vector<uint8_t>> blocks;
  blocks.push_back(std::vector<uint8_t>(300, 0x41)); // compresses
  blocks.push_back({});
  std::vector<uint8_t> noise(257);
  for (auto& b : noise) b = uint8_t(rng());
  blocks.push_back(noise); // stored raw: zstd would make it larger
  blocks.push_back({9});
  std::vector<uint8_t> text;
  for (int i = 0; i < 2000; ++i) text.push_back(uint8_t('a' + i % 7 + (i / 97) % 3));
  blocks.push_back(text);
  return blocks;
}

std::vector<uint8_t> samplePayload(const std::vector<std::vector<uint8_t>>& blocks, int level = 3) {
  std::vector<std::span<const uint8_t>> spans(blocks.begin(), blocks.end());
  const std::vector<uint8_t> header = {'h', 'e', 'a', 'd'};
  Result<std::vector<uint8_t>> payload = encodeBlocks(header, spans, level);
  EXPECT_TRUE(payload.ok()) << payload.error().message;
  return payload ? *payload : std::vector<uint8_t>{};
}

// Recomputes a blocked payload's index checksum after a test patched the index.
void resealIndex(std::vector<uint8_t>& payload) {
  BlockIndexHeader h;
  std::memcpy(&h, payload.data(), sizeof(h));
  uint64_t indexBytes = sizeof(h) + uint64_t(h.blockCount) * sizeof(BlockEntry) + h.headerBytes;
  std::vector<uint8_t> copy(payload.begin(),
                            payload.begin() + std::ptrdiff_t(std::min<uint64_t>(indexBytes, payload.size())));
  std::memset(copy.data() + offsetof(BlockIndexHeader, indexHash), 0, 8);
  h.indexHash = XXH3_64bits(copy.data(), copy.size());
  std::memcpy(payload.data(), &h, sizeof(h));
}

} // namespace

TEST(BlockedChunks, PayloadRoundTripIsExact) {
  auto blocks = sampleBlocks();
  std::vector<uint8_t> payload = samplePayload(blocks);
  Result<BlockPrefix> all = decodeBlocks(payload, "p");
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->raw, blocks);
  EXPECT_EQ(all->table.header, (std::vector<uint8_t>{'h', 'e', 'a', 'd'}));
  EXPECT_EQ(all->table.payloadBytes, payload.size());
  EXPECT_EQ(all->table.indexBytes, sizeof(BlockIndexHeader) + blocks.size() * sizeof(BlockEntry) + 4);
  EXPECT_TRUE(all->table.blocks[0].compressed);
  EXPECT_FALSE(all->table.blocks[2].compressed); // noise stays raw
  uint64_t raw = 0;
  for (const auto& b : blocks) raw += b.size();
  EXPECT_EQ(all->table.rawBytes, raw);
  // Level 0 stores every block raw; the blocks still come back exactly.
  Result<BlockPrefix> stored = decodeBlocks(samplePayload(blocks, 0), "p");
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(stored->raw, blocks);
  for (const BlockInfo& b : stored->table.blocks) EXPECT_FALSE(b.compressed);
  // Encoding is deterministic: the same blocks give the same bytes.
  EXPECT_EQ(samplePayload(blocks), payload);
  // No blocks at all: an index alone.
  Result<BlockPrefix> none = decodeBlocks(samplePayload({}), "p");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->complete());
  EXPECT_TRUE(none->raw.empty());
}

TEST(BlockedChunks, FileRoundTripBlockByBlockAndCopies) {
  TempDir dir;
  auto blocks = sampleBlocks();
  std::vector<uint8_t> payload = samplePayload(blocks);
  std::vector<uint8_t> plain = {1, 2, 3, 4, 5};
  AssetWriter w;
  w.addChunk(chunk::Meta, plain);
  w.addBlockedChunk(chunk::Surfels, payload);
  ASSERT_TRUE(w.write(dir.file("b.mrg")).ok());
  Result<AssetReader> r = AssetReader::open(dir.file("b.mrg"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->version(), 2u);
  const ChunkInfo& c = r->chunks()[1];
  EXPECT_TRUE(c.blocked);
  EXPECT_FALSE(c.compressed);
  EXPECT_EQ(c.storedBytes, payload.size());
  EXPECT_EQ(c.rawHash, 0u);
  EXPECT_EQ(*r->readChunk(0), plain);
  EXPECT_EQ(*r->readChunk(1), payload); // a blocked chunk reads back as stored
  Result<BlockTable> table = r->readBlockTable(1);
  ASSERT_TRUE(table.ok()) << table.error().message;
  EXPECT_EQ(c.indexBytes, table->indexBytes);
  // Any block alone, in any order.
  for (size_t i = blocks.size(); i-- > 0;) {
    Result<std::vector<uint8_t>> b = r->readBlock(1, *table, i);
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_EQ(*b, blocks[i]) << i;
  }
  EXPECT_FALSE(r->readBlock(1, *table, blocks.size()).ok());
  EXPECT_FALSE(r->readBlockTable(0).ok()); // not blocked
  // Copied as stored into another file: the same bytes, still blocked.
  AssetWriter copy;
  copy.addStoredChunk(c, *r->readStoredChunk(1));
  ASSERT_TRUE(copy.write(dir.file("copy.mrg")).ok());
  Result<AssetReader> rc = AssetReader::open(dir.file("copy.mrg"));
  ASSERT_TRUE(rc.ok()) << rc.error().message;
  EXPECT_TRUE(rc->chunks()[0].blocked);
  EXPECT_EQ(*rc->readChunk(0), payload);
  // A file without blocked chunks stays version 1 (readable by builds that predate blocks).
  AssetWriter v1;
  v1.addChunk(chunk::Meta, plain);
  ASSERT_TRUE(v1.write(dir.file("v1.mrg")).ok());
  EXPECT_EQ(header(readBytes(dir.file("v1.mrg"))).version, 1u);
  EXPECT_EQ(AssetReader::open(dir.file("v1.mrg"))->version(), 1u);
  // A payload whose index does not decode is refused by the writer.
  AssetWriter bad;
  bad.addBlockedChunk(chunk::Surfels, plain);
  EXPECT_FALSE(bad.write(dir.file("bad.mrg")).ok());
  EXPECT_FALSE(fs::exists(dir.file("bad.mrg")));
}

TEST(BlockedChunks, EveryBytePrefixDecodesToItsCompleteBlocks) {
  auto blocks = sampleBlocks();
  std::vector<uint8_t> payload = samplePayload(blocks);
  Result<BlockTable> table = decodeBlockTable(payload, "p");
  ASSERT_TRUE(table.ok());
  for (size_t n = 0; n <= payload.size(); ++n) {
    Result<BlockPrefix> p = decodeBlockPrefix(std::span(payload).first(n), "p");
    ASSERT_TRUE(p.ok()) << n << ": " << p.error().message;
    EXPECT_EQ(p->haveIndex, n >= table->indexBytes) << n;
    size_t complete = 0;
    while (complete < blocks.size() && p->haveIndex &&
           table->blocks[complete].offset + table->blocks[complete].storedBytes <= n)
      ++complete;
    ASSERT_EQ(p->raw.size(), complete) << n;
    for (size_t i = 0; i < complete; ++i) ASSERT_EQ(p->raw[i], blocks[i]) << n << " block " << i;
    // nextBytes: the length that adds something (the index, then the next block).
    uint64_t next = !p->haveIndex ? (n < sizeof(BlockIndexHeader) ? sizeof(BlockIndexHeader) : table->indexBytes)
                    : complete < blocks.size() ? table->blocks[complete].offset + table->blocks[complete].storedBytes
                                               : payload.size();
    EXPECT_EQ(p->nextBytes, next) << n;
    EXPECT_EQ(p->complete(), n == payload.size()) << n;
    if (n < payload.size()) {
      EXPECT_FALSE(decodeBlocks(std::span(payload).first(n), "p").ok()) << n;
    }
  }
  std::vector<uint8_t> longer = payload;
  longer.push_back(0);
  Result<BlockPrefix> p = decodeBlockPrefix(longer, "p");
  ASSERT_FALSE(p.ok());
  EXPECT_TRUE(contains(p.error().message, "bytes after the last block")) << p.error().message;
}

TEST(BlockedChunks, EveryByteFlipInABlockIsRejectedNamingIt) {
  TempDir dir;
  auto blocks = sampleBlocks();
  std::vector<uint8_t> payload = samplePayload(blocks);
  AssetWriter w;
  w.addBlockedChunk(chunk::Surfels, payload);
  std::string path = dir.file("flip.mrg");
  ASSERT_TRUE(w.write(path).ok());
  const std::vector<uint8_t> valid = readBytes(path);
  const uint64_t at = entry(valid, 0).offset;
  Result<BlockTable> table = decodeBlockTable(payload, "p");
  ASSERT_TRUE(table.ok());
  for (size_t byte = 0; byte < payload.size(); ++byte) {
    std::vector<uint8_t> file = valid;
    file[at + byte] ^= 0x10;
    writeBytes(path, file);
    Result<AssetReader> r = AssetReader::open(path); // the container's own structure is intact
    ASSERT_TRUE(r.ok()) << r.error().message;
    Result<std::vector<uint8_t>> whole = r->readChunk(0);
    ASSERT_FALSE(whole.ok()) << "flip at payload byte " << byte << " accepted";
    const std::string& m = whole.error().message;
    EXPECT_TRUE(contains(m, path) && contains(m, "chunk 0 'SURF'")) << m;
    if (byte < table->indexBytes) {
      EXPECT_TRUE(contains(m, "block index checksum mismatch")) << m;
      EXPECT_FALSE(r->readBlockTable(0).ok()) << byte;
      continue;
    }
    size_t hit = 0;
    while (table->blocks[hit].offset + table->blocks[hit].storedBytes <= byte) ++hit;
    EXPECT_TRUE(contains(m, "block " + std::to_string(hit) + " checksum mismatch")) << byte << ": " << m;
    // Read piecewise, the damaged block fails with the same words and the others still read.
    Result<BlockTable> t = r->readBlockTable(0);
    ASSERT_TRUE(t.ok()) << t.error().message;
    for (size_t i = 0; i < blocks.size(); ++i) {
      Result<std::vector<uint8_t>> b = r->readBlock(0, *t, i);
      EXPECT_EQ(b.ok(), i != hit) << byte << " block " << i;
      if (!b) {
        EXPECT_TRUE(contains(b.error().message, path + ": chunk 0 'SURF': block " + std::to_string(i)))
            << b.error().message;
      }
    }
    // The prefix reader returns the blocks before the damage, then reports it once it is complete.
    std::span<const uint8_t> damaged(file.data() + at, payload.size());
    Result<BlockPrefix> before = decodeBlockPrefix(damaged.first(size_t(table->blocks[hit].offset)), "p");
    ASSERT_TRUE(before.ok()) << before.error().message;
    EXPECT_EQ(before->raw.size(), hit);
    EXPECT_FALSE(decodeBlockPrefix(damaged, "p").ok());
  }
}

TEST(BlockedChunks, CraftedIndicesWithValidChecksumsAreRejected) {
  std::vector<uint8_t> valid = samplePayload(sampleBlocks());
  auto entryAt = [](size_t i) { return sizeof(BlockIndexHeader) + i * sizeof(BlockEntry); };
  struct Case {
    const char* expect;
    std::function<void(BlockIndexHeader&, std::vector<uint8_t>&)> patch;
  };
  auto patchEntry = [&](size_t i, auto f) {
    return [=](BlockIndexHeader&, std::vector<uint8_t>& p) {
      BlockEntry e;
      std::memcpy(&e, p.data() + entryAt(i), sizeof(e));
      f(e);
      std::memcpy(p.data() + entryAt(i), &e, sizeof(e));
    };
  };
  const Case cases[] = {
      {"bad block index magic", [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.magic = 0; }},
      {"unsupported block index version 2 (this build reads version 1; rebuild the file",
       [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.version = 2; }},
      {"block count 4294967295 exceeds", [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.blockCount = ~0u; }},
      {"block header of", [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.headerBytes = ~0u; }},
      {"larger than its payload", [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.payloadBytes = 10; }},
      {"but the payload is", [](BlockIndexHeader& h, std::vector<uint8_t>&) { h.payloadBytes += 1; }},
      {"block 1 offset", patchEntry(1, [](BlockEntry& e) { e.offset -= 1; })},
      {"block 4 (", patchEntry(4, [](BlockEntry& e) { e.storedBytes = ~0u; })},
      {"over the limit", patchEntry(2, [](BlockEntry& e) { e.rawBytes = ~0u; })},
      {"stored raw but its sizes differ", patchEntry(2, [](BlockEntry& e) { e.rawBytes += 1; })},
      {"sizes are inconsistent", patchEntry(0, [](BlockEntry& e) { e.rawBytes = e.storedBytes; })},
      {"unknown flags", patchEntry(3, [](BlockEntry& e) { e.flags |= 4; })},
      {"non-zero reserved", patchEntry(3, [](BlockEntry& e) { e.reserved = 1; })},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> p = valid;
    BlockIndexHeader h;
    std::memcpy(&h, p.data(), sizeof(h));
    c.patch(h, p);
    std::memcpy(p.data(), &h, sizeof(h));
    resealIndex(p);
    Result<BlockPrefix> r = decodeBlockPrefix(p, "crafted");
    ASSERT_FALSE(r.ok()) << c.expect;
    EXPECT_TRUE(contains(r.error().message, "crafted: ")) << r.error().message;
    EXPECT_TRUE(contains(r.error().message, c.expect)) << c.expect << ": " << r.error().message;
  }
  // A resealed index whose stored checksum of a block is wrong: that block is named.
  std::vector<uint8_t> p = valid;
  BlockIndexHeader unused{};
  patchEntry(2, [](BlockEntry& e) { e.storedHash ^= 1; })(unused, p);
  resealIndex(p);
  Result<BlockPrefix> r = decodeBlocks(p, "crafted");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "block 2 checksum mismatch")) << r.error().message;
  // The raw checksum catches what the stored one cannot (a consistent index over other bytes).
  p = valid;
  patchEntry(0, [](BlockEntry& e) { e.rawHash ^= 1; })(unused, p);
  resealIndex(p);
  r = decodeBlocks(p, "crafted");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "block 0 uncompressed checksum mismatch")) << r.error().message;
  // An unsealed edit of the index is caught by its checksum.
  p = valid;
  p[entryAt(1) + 3] ^= 1;
  r = decodeBlockPrefix(p, "crafted");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "block index checksum mismatch")) << r.error().message;
}

TEST(BlockedChunks, ContainerEntryChecks) {
  TempDir dir;
  AssetWriter w;
  w.addBlockedChunk(chunk::Surfels, samplePayload(sampleBlocks()));
  ASSERT_TRUE(w.write(dir.file("e.mrg")).ok());
  const std::vector<uint8_t> valid = readBytes(dir.file("e.mrg"));
  struct Case {
    const char* expect;
    std::function<void(FileHeader&, ChunkEntry&)> patch;
  };
  const Case cases[] = {
      {"blocked but also marked compressed", [](FileHeader&, ChunkEntry& e) { e.flags |= kChunkZstd; }},
      {"checksum of its raw bytes", [](FileHeader&, ChunkEntry& e) { e.rawHash = 1; }},
      {"does not fit", [](FileHeader&, ChunkEntry& e) { e.indexBytes = e.storedBytes + 1; }},
      {"does not fit", [](FileHeader&, ChunkEntry& e) { e.indexBytes = 8; }},
      {"block index checksum mismatch", [](FileHeader&, ChunkEntry& e) { e.indexBytes -= 1; }},
      {"disagrees with the chunk table", [](FileHeader&, ChunkEntry& e) { e.rawBytes += 1; }},
      {"unknown flags", [](FileHeader& h, ChunkEntry&) { h.version = 1; }}, // version 1 had no blocked chunks
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> file = valid;
    FileHeader h = header(file);
    ChunkEntry e = entry(file, 0);
    c.patch(h, e);
    setEntry(file, 0, e);
    setHeader(file, h);
    reseal(file);
    writeBytes(dir.file("x.mrg"), file);
    std::string error;
    Result<AssetReader> r = AssetReader::open(dir.file("x.mrg"));
    if (!r) {
      error = r.error().message;
    } else {
      Result<std::vector<uint8_t>> bytes = r->readChunk(0);
      Result<BlockTable> table = r->readBlockTable(0);
      EXPECT_EQ(bytes.ok(), table.ok()) << c.expect;
      error = bytes ? "accepted" : bytes.error().message;
    }
    EXPECT_TRUE(contains(error, c.expect)) << c.expect << ": " << error;
  }
}
