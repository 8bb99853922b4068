// Every corruption of a .mrg is a clean one-line error (or, for bytes the format does not read,
// an identical scene) and never a crash, a hang or a huge allocation.
#include <random>

#include "asset_test_util.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"

using namespace mirage;
using namespace mirage::asset;
using namespace mirage::asset::test;

namespace {

// A small valid file: the full test scene (SCEN + META).
std::vector<uint8_t> smallFile(const TempDir& dir) {
  std::string path = dir.file("valid.mrg");
  Status st = saveScene(path, makeFullScene());
  EXPECT_TRUE(st.ok()) << st.error().message;
  return readBytes(path);
}

// Write `bytes` and load them as a scene; returns the error message, or "" on success.
std::string loadError(const TempDir& dir, const std::vector<uint8_t>& bytes, Scene* out = nullptr) {
  std::string path = dir.file("case.mrg");
  writeBytes(path, bytes);
  Result<Scene> s = loadScene(path);
  if (s.ok()) {
    if (out) *out = std::move(*s);
    return "";
  }
  expectOneLineError(s.error().message, path);
  return s.error().message;
}

// Bytes no check covers: alignment padding between the table and payloads, and between payloads.
std::vector<bool> paddingMask(const std::vector<uint8_t>& file) {
  std::vector<bool> pad(file.size(), true);
  FileHeader h = header(file);
  auto mark = [&](uint64_t from, uint64_t n) {
    for (uint64_t i = from; i < from + n; ++i) pad[i] = false;
  };
  mark(0, sizeof(FileHeader));
  mark(h.tableOffset, uint64_t(h.chunkCount) * sizeof(ChunkEntry));
  for (size_t i = 0; i < h.chunkCount; ++i) mark(entry(file, i).offset, entry(file, i).storedBytes);
  return pad;
}

} // namespace

TEST(Corruption, WrongMagic) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  file[0] = 'X';
  EXPECT_TRUE(contains(loadError(dir, file), "not a Mirage asset (bad magic)"));
  EXPECT_TRUE(contains(loadError(dir, {}), "bad magic"));
  std::vector<uint8_t> text{'{', '"', 'a', '"', ':', '1', '}'};
  EXPECT_TRUE(contains(loadError(dir, text), "bad magic"));
}

TEST(Corruption, WrongVersionNamesBoth) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  FileHeader h = header(file);
  h.version = kFormatVersion + 1;
  setHeader(file, h);
  std::string newer = "unsupported .mrg format version 3 (this build reads versions 1 to 2; read it with a newer "
                      "mirage, or rebuild it with this one's mirage build)";
  EXPECT_TRUE(contains(loadError(dir, file), newer)) << loadError(dir, file);
  reseal(file); // a correctly sealed future file gets the same message
  EXPECT_TRUE(contains(loadError(dir, file), newer));
  h.version = 0; // older than any reader knows
  setHeader(file, h);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "version 0 (this build reads versions 1 to 2; rebuild it with mirage "
                                             "build)"))
      << loadError(dir, file);
}

TEST(Corruption, TruncatedAtEveryLength) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  ASSERT_LT(file.size(), 4096u) << "keep the loop small";
  for (size_t n = 0; n < file.size(); ++n) {
    std::vector<uint8_t> cut(file.begin(), file.begin() + std::ptrdiff_t(n));
    EXPECT_FALSE(loadError(dir, cut).empty()) << "truncated to " << n;
  }
  std::vector<uint8_t> longer = file;
  longer.push_back(0);
  EXPECT_TRUE(contains(loadError(dir, longer), "trailing bytes"));
}

TEST(Corruption, FlippedBitAtEveryByte) {
  TempDir dir;
  const Scene original = makeFullScene();
  std::vector<uint8_t> file = smallFile(dir);
  std::vector<bool> padding = paddingMask(file);
  size_t paddingFlips = 0;
  for (size_t i = 0; i < file.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> bad = file;
      bad[i] ^= uint8_t(1u << bit);
      Scene decoded;
      std::string err = loadError(dir, bad, &decoded);
      if (padding[i]) {
        // Padding is not read: the file still loads, to exactly the same scene.
        ASSERT_EQ(err, "") << "byte " << i;
        expectSameScene(decoded, original);
        ++paddingFlips;
      } else {
        EXPECT_NE(err, "") << "flip of bit " << bit << " at byte " << i << " went unnoticed";
      }
    }
  }
  RecordProperty("paddingFlips", int(paddingFlips)); // in the XML report: how many flips hit padding
}

TEST(Corruption, ChunkOffsetPastEndOfFile) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  ChunkEntry e = entry(file, 0);
  e.offset = (file.size() + 16 * 100) / 16 * 16; // aligned, so the bounds check is what fails
  setEntry(file, 0, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "runs past the end of the file"));
  // A stored size that would wrap offset + size around 2^64.
  e = entry(smallFile(dir), 0);
  file = smallFile(dir);
  e.storedBytes = ~uint64_t(0) - 8;
  setEntry(file, 0, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "runs past the end of the file")) << loadError(dir, file);
}

TEST(Corruption, OverlappingChunks) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  ChunkEntry e = entry(file, 1);
  e.offset = entry(file, 0).offset;
  setEntry(file, 1, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "chunks 0 and 1 overlap"));
  // A payload placed on top of the chunk table.
  file = smallFile(dir);
  e = entry(file, 0);
  e.offset = header(file).tableOffset;
  setEntry(file, 0, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "overlaps the header/table"));
}

TEST(Corruption, HugeUncompressedSize) {
  TempDir dir;
  std::vector<uint8_t> file = smallFile(dir);
  ASSERT_TRUE(entry(file, 0).flags & kChunkZstd) << "the scene chunk should be compressed";
  ChunkEntry e = entry(file, 0);
  e.rawBytes = uint64_t(1) << 60;
  setEntry(file, 0, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "over the limit"));
  // Under the limit but not what the zstd frame declares: rejected before allocating 32 GiB.
  e.rawBytes = uint64_t(1) << 35;
  setEntry(file, 0, e);
  reseal(file);
  EXPECT_TRUE(contains(loadError(dir, file), "zstd frame size does not match"));
}

TEST(Corruption, StructuralFieldsBehindTheChecksums) {
  TempDir dir;
  const std::vector<uint8_t> valid = smallFile(dir);
  struct Case {
    const char* expect;
    std::function<void(FileHeader&, ChunkEntry&)> patch;
  };
  const Case cases[] = {
      {"chunk count", [](FileHeader& h, ChunkEntry&) { h.chunkCount = 0xffffffffu; }},
      {"runs past the end", [](FileHeader& h, ChunkEntry&) { h.chunkCount = 1000; }},
      {"table offset", [](FileHeader& h, ChunkEntry&) { h.tableOffset = 8; }},
      {"header size", [](FileHeader& h, ChunkEntry&) { h.headerBytes = 128; }},
      {"reserved header", [](FileHeader& h, ChunkEntry&) { h.flags = 1; }},
      {"unknown flags", [](FileHeader&, ChunkEntry& e) { e.flags |= 0x80; }},
      {"unaligned", [](FileHeader&, ChunkEntry& e) { e.offset += 4; }},
      {"reserved fields", [](FileHeader&, ChunkEntry& e) { e.indexBytes = 5; }},
      {"unknown flags", [](FileHeader&, ChunkEntry& e) { e.flags = kChunkBlocked; }}, // version 1: not yet a flag
      {"sizes are inconsistent", [](FileHeader&, ChunkEntry& e) { e.rawBytes = e.storedBytes; }},
      {"stored raw", [](FileHeader&, ChunkEntry& e) { e.flags = 0; }},
      {"checksum mismatch", [](FileHeader&, ChunkEntry& e) { e.storedHash ^= 1; }},
      {"uncompressed checksum", [](FileHeader&, ChunkEntry& e) { e.rawHash ^= 1; }},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> file = valid;
    FileHeader h = header(file);
    ChunkEntry e = entry(file, 0);
    c.patch(h, e);
    setEntry(file, 0, e); // table first: setEntry reads the (still valid) table offset
    setHeader(file, h);
    reseal(file);
    EXPECT_TRUE(contains(loadError(dir, file), c.expect)) << c.expect << ": " << loadError(dir, file);
  }
  // Unsealed edits are caught by the checksums themselves.
  std::vector<uint8_t> file = valid;
  file[offsetof(FileHeader, fileBytes)] ^= 1;
  EXPECT_TRUE(contains(loadError(dir, file), "header checksum mismatch"));
  file = valid;
  file[header(valid).tableOffset + 20] ^= 1;
  EXPECT_TRUE(contains(loadError(dir, file), "chunk table checksum mismatch"));
}

TEST(Corruption, FuzzRandomBytesAndMutations) {
  TempDir dir;
  const std::vector<uint8_t> valid = smallFile(dir);
  std::mt19937_64 rng(12345);
  auto pick = [&](uint64_t n) { return n ? rng() % n : 0; };
  int loaded = 0;
  for (int iter = 0; iter < 3000; ++iter) {
    std::vector<uint8_t> file;
    switch (iter % 4) {
    case 0: // random bytes, half of them behind a valid magic and version
      file.resize(pick(600));
      for (auto& b : file) b = uint8_t(rng());
      if (iter % 8 == 0 && file.size() >= 12) {
        std::memcpy(file.data(), kMagic, 8);
        std::memcpy(file.data() + 8, &kFormatVersion, 4);
      }
      break;
    case 1: // a few random byte writes anywhere
      file = valid;
      for (int k = 0, n = 1 + int(pick(8)); k < n; ++k) file[pick(file.size())] = uint8_t(rng());
      break;
    case 2: // random edits of header and table fields, resealed to reach the structural checks
      file = valid;
      for (int k = 0, n = 1 + int(pick(4)); k < n; ++k) {
        size_t at = pick(header(valid).tableOffset + 2 * sizeof(ChunkEntry));
        if (at >= offsetof(FileHeader, tableHash) && at < sizeof(FileHeader)) continue; // keep hashes to reseal
        file[at] = uint8_t(rng());
      }
      reseal(file);
      break;
    case 3: // insertions, deletions and truncations
      file = valid;
      if (rng() % 2)
        file.insert(file.begin() + std::ptrdiff_t(pick(file.size())), uint8_t(rng()));
      else
        file.erase(file.begin() + std::ptrdiff_t(pick(file.size())));
      if (rng() % 3 == 0) file.resize(pick(file.size()));
      break;
    }
    Scene s;
    if (loadError(dir, file, &s).empty()) {
      ++loaded;
      expectSameScene(s, makeFullScene()); // only padding or unread bytes may change
    }
  }
  EXPECT_GT(loaded, 0); // some mutations land in padding (a hang is ctest's timeout, not a timed assertion)
}
