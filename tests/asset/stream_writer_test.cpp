// AssetStreamWriter, resumable: a write stopped after its checkpoints (the writer dropped as a killed
// process leaves it, a chunk cut short after the last mark, the header and table written by a
// finish that did not reach its rename) continues to the bytes of an uninterrupted write; the marks
// name the first range whose bytes differ, and a file cut short matches fewer marks.
#include <random>

#include "asset_test_util.h"
#include "mirage/asset/container.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::asset;
using namespace mirage::asset::test;

namespace {

// Compressible: zstd frames and raw chunks both occur.
std::vector<uint8_t> someBytes(size_t n, uint32_t seed) { return randomBytes(n, seed, 7); }

// Chunks of odd sizes (padding between them), compressed and not.
std::vector<std::vector<uint8_t>> payloads() { return {someBytes(1001, 1), someBytes(37, 2), someBytes(5003, 3)}; }
constexpr uint32_t kChunks = 5;

Status addAll(AssetStreamWriter& w, const std::vector<std::vector<uint8_t>>& chunks, size_t from, size_t to) {
  for (size_t i = from; i < to; ++i)
    if (Status s = w.addChunk(chunk::Surfels, chunks[i], i == 1 ? 0 : 3); !s) return s;
  return Ok{};
}

} // namespace

TEST(StreamWriter, ResumedWriteHasTheUninterruptedBytes) {
  TempDir dir;
  auto chunks = payloads();
  {
    auto w = AssetStreamWriter::create(dir.file("whole.mrg"), kChunks);
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(addAll(*w, chunks, 0, 3).ok());
    ASSERT_TRUE(w->addChunk(chunk::Meta, someBytes(64, 4)).ok());
    ASSERT_TRUE(w->finish().ok());
  }
  const std::string out = dir.file("a.mrg"), partial = dir.file("a.mrg.partial");
  std::vector<FileMark> marks;
  std::vector<ChunkEntry> table;
  {
    auto w = AssetStreamWriter::createResumable(out, partial, kChunks);
    ASSERT_TRUE(w.ok()) << w.error().message;
    for (size_t i = 0; i < 2; ++i) {
      ASSERT_TRUE(addAll(*w, chunks, i, i + 1).ok());
      auto mark = w->checkpoint();
      ASSERT_TRUE(mark.ok()) << mark.error().message;
      marks.push_back(*mark);
    }
    table.assign(w->table().begin(), w->table().end());
    ASSERT_TRUE(addAll(*w, chunks, 2, 3).ok()); // written, never marked
  }                                             // dropped as a killed process leaves it: the partial file stays
  ASSERT_TRUE(fs::exists(partial));
  std::vector<uint8_t> bytes = readBytes(partial);
  ASSERT_GT(bytes.size(), marks.back().end);
  bytes.resize(size_t(marks.back().end) + 100); // the unmarked chunk cut short, then bytes of no chunk
  bytes.resize(bytes.size() + 20000, 0xcd);
  // As if finish() wrote a header and table (the whole reserved region, unused slots too).
  std::fill(bytes.begin(), bytes.begin() + ptrdiff_t(AssetStreamWriter::payloadStart(kChunks)), 0xab);
  writeBytes(partial, bytes);
  EXPECT_EQ(*matchingFileMarks(partial, AssetStreamWriter::payloadStart(kChunks), marks), 2u);

  auto w = AssetStreamWriter::resume(out, partial, kChunks, table, marks.back().end);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_TRUE(addAll(*w, chunks, 2, 3).ok());
  ASSERT_TRUE(w->addChunk(chunk::Meta, someBytes(64, 4)).ok());
  ASSERT_TRUE(w->finish().ok());
  EXPECT_EQ(readBytes(out), readBytes(dir.file("whole.mrg")));
  EXPECT_FALSE(fs::exists(partial)); // renamed into place
}

TEST(StreamWriter, MarksFindTheFirstDifferentRange) {
  TempDir dir;
  const std::string partial = dir.file("a.mrg.partial");
  std::vector<FileMark> marks;
  {
    auto w = AssetStreamWriter::createResumable(dir.file("a.mrg"), partial, kChunks);
    ASSERT_TRUE(w.ok());
    auto chunks = payloads();
    for (size_t i = 0; i < 3; ++i) {
      ASSERT_TRUE(addAll(*w, chunks, i, i + 1).ok());
      marks.push_back(*w->checkpoint());
    }
  }
  const uint64_t start = AssetStreamWriter::payloadStart(kChunks);
  EXPECT_EQ(*matchingFileMarks(partial, start, marks), 3u);
  EXPECT_EQ(*matchingFileMarks(partial, start + 16, marks), 0u); // ranges start where the payloads do
  mirage::test::flipByte(partial, marks[0].end + 5);             // inside the second chunk
  EXPECT_EQ(*matchingFileMarks(partial, start, marks), 1u);
  fs::resize_file(partial, marks[0].end + 1);
  EXPECT_EQ(*matchingFileMarks(partial, start, std::span(marks).first(1)), 1u);
  fs::resize_file(partial, marks[0].end - 1); // shorter than the first mark
  EXPECT_EQ(*matchingFileMarks(partial, start, marks), 0u);
  EXPECT_FALSE(matchingFileMarks(dir.file("missing"), start, marks).ok());
  // Resuming past the file's end is refused.
  EXPECT_FALSE(AssetStreamWriter::resume(dir.file("a.mrg"), partial, kChunks, {}, marks[0].end).ok());
}
