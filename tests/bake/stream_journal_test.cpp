// The streaming bake's journal (bake::bakeLodFile with run.resume, docs/bake.md "Journal and
// --resume"): a bake killed after K meshes (the journal holding K records and a torn entry, the
// partial output holding a mesh more and a half-written one) resumes to the bytes of an
// uninterrupted bake, baking no resumed mesh on any rank; a journal of another bake, a damaged one
// and a damaged partial output are refused with one line and left as they are; a failed bake and a
// finished one leave nothing; a bake without --resume removes an earlier one's files at the end.
// Distributed.StreamBakeResumesOnEveryRank also runs on 4 ranks (bake.mpi).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "mirage/bake/journal.h"
#include "mirage/bake/lod_bake.h"
#include "mirage/bake/lod_stream_bake.h"
#include "mirage/io/generate.h"
#include "bake_test_util.h"
#include "test_support.h"

using namespace mirage;
namespace fs = std::filesystem;

namespace {

const io::ManyOptions kMany{.count = 6, .triangles = 3000, .seed = 7};

lod::MeshSource source(const io::ManyOptions& o = kMany) {
  lod::MeshSource s;
  s.layout = io::generateManyLayout(o);
  s.mesh = [o](uint32_t i) -> Result<Mesh> { return io::generateManyMesh(o, i); };
  s.key = "gen:many:" + std::to_string(o.count) + "x" + std::to_string(o.triangles) + ":" + std::to_string(o.seed);
  return s;
}

lod::LodWriteOptions paged() {
  lod::LodWriteOptions w;
  w.paged = true;
  w.pages.pageBytes = 16 * 1024;
  return w;
}

lod::BuildConfig config(float normalWeight = 12.0f) {
  lod::BuildConfig c;
  c.threads = 2;
  c.normalWeight = normalWeight;
  return c;
}

// What a process killed after writing mesh `killedAt` (its record not yet journaled) leaves: the
// journal of meshes 0..killedAt-1 with the start of a next entry, the partial output with mesh
// killedAt and half of another mesh, the spool likewise.
void killedBake(const fs::path& out, const lod::LodWriteOptions& w, uint32_t killedAt) {
  lod::MeshSource s = source();
  std::string journalPath = bake::journalPath(out.string());
  auto journal = bake::Journal::open(journalPath, bake::streamFingerprint(s, config(), w), kMany.count, 0);
  ASSERT_TRUE(journal.ok());
  lod::StreamJournal stream{{}, [&](uint32_t mesh, std::span<const uint8_t> record) -> Status {
                              if (mesh == killedAt) return Error{"killed"};
                              return journal->append(mesh, record);
                            }};
  Status s2 =
      lod::bakeLodFile(s, out.string(), config(), w, {.meshesInFlight = 2}, nullptr, {}, nullptr, nullptr, &stream);
  ASSERT_FALSE(s2.ok());
  ASSERT_EQ(s2.error().message, "killed");
  for (auto [file, n] : {std::pair{journalPath, 9},
                         {lod::streamPartialPath(out.string()), 5000},
                         {lod::streamSpoolPath(out.string()), 40}})
    std::ofstream(file, std::ios::binary | std::ios::app) << std::string(size_t(n), '\x07');
}

// The files a bake to `out` may leave beside it.
std::vector<std::string> leftBeside(const fs::path& out) {
  std::vector<std::string> left;
  for (const std::string& f :
       {bake::journalPath(out.string()), lod::streamPartialPath(out.string()), lod::streamSpoolPath(out.string())})
    if (fs::exists(f)) left.push_back(f);
  return left;
}

} // namespace

TEST(StreamJournal, KilledBakeResumesToTheSameBytes) {
  fs::path dir = test::tempDir("stream_resume");
  for (bool isPaged : {true, false}) {
    SCOPED_TRACE(isPaged ? "paged" : "flat");
    lod::LodWriteOptions w = isPaged ? paged() : lod::LodWriteOptions{};
    // The reference, uninterrupted and not resumable.
    ASSERT_TRUE(bake::bakeLodFile(test::world(), source(), (dir / "whole.mrg").string(), config(), w, {}).ok());
    fs::path out = dir / "out.mrg";
    killedBake(out, w, 3);
    lod::StreamBakeReport report;
    bake::ScheduleReport ranks;
    Status s = bake::bakeLodFile(test::world(), source(), out.string(), config(), w, {}, &report, &ranks, {},
                                 {bake::journalPath(out.string()), true});
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_EQ(test::fileBytes(out), test::fileBytes(dir / "whole.mrg"));
    EXPECT_EQ(report.resumedMeshes, 3u);
    EXPECT_EQ(ranks.resumedUnits, 3u);
    EXPECT_EQ(ranks.ranks[0].units.size(), kMany.count - 3);
    for (uint32_t m : ranks.ranks[0].units) EXPECT_GE(m, 3u) << "a resumed mesh baked again";
    EXPECT_TRUE(leftBeside(out).empty());
    // --resume with nothing to resume: a new bake, journaled, with the same bytes.
    fs::remove(out);
    ASSERT_TRUE(bake::bakeLodFile(test::world(), source(), out.string(), config(), w, {}, &report, nullptr, {},
                                  {bake::journalPath(out.string()), true})
                    .ok());
    EXPECT_EQ(report.resumedMeshes, 0u);
    EXPECT_EQ(test::fileBytes(out), test::fileBytes(dir / "whole.mrg"));
    EXPECT_TRUE(leftBeside(out).empty());
    fs::remove(out);
  }
  fs::remove_all(dir);
}

TEST(StreamJournal, OtherOrDamagedJournalsAreRefused) {
  fs::path dir = test::tempDir("stream_refused");
  fs::path out = dir / "out.mrg";
  const std::string journal = bake::journalPath(out.string()), partial = lod::streamPartialPath(out.string());
  killedBake(out, paged(), 3);
  const std::vector<uint8_t> journalBytes = test::fileBytes(journal), partialBytes = test::fileBytes(partial);
  bake::BakeRun resume{journal, true};
  auto refusal = [&](const lod::MeshSource& s, const lod::BuildConfig& c, const lod::LodWriteOptions& w) {
    const std::vector<uint8_t> journalBefore = test::fileBytes(journal), partialBefore = test::fileBytes(partial);
    Status st = bake::bakeLodFile(test::world(), s, out.string(), c, w, {}, nullptr, nullptr, {}, resume);
    EXPECT_FALSE(st.ok());
    std::string message = st.ok() ? "" : st.error().message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_EQ(test::fileBytes(journal), journalBefore) << "a refused journal is left as it is";
    EXPECT_EQ(test::fileBytes(partial), partialBefore);
    return message;
  };
  // Other settings, another scene, other write options.
  EXPECT_NE(refusal(source(), config(3.0f), paged()).find(journal + ": journal of another bake"), std::string::npos);
  io::ManyOptions other = kMany;
  other.seed = 8;
  EXPECT_NE(refusal(source(other), config(), paged()).find("journal of another bake"), std::string::npos);
  EXPECT_NE(refusal(source(), config(), {}).find("journal of another bake"), std::string::npos);
  // Damaged: an entry's byte, or the partial output's (mesh 1's chunk).
  test::flipByte(journal, journalBytes.size() - 40);
  std::string damaged = refusal(source(), config(), paged());
  EXPECT_NE(damaged.find(journal + ": damaged bake journal"), std::string::npos) << damaged;
  test::flipByte(journal, journalBytes.size() - 40);
  auto read = bake::readJournal(journal, bake::streamFingerprint(source(), config(), paged()), kMany.count);
  ASSERT_TRUE(read.ok() && read->entries.size() == 3u);
  std::vector<std::vector<uint8_t>> records;
  for (const bake::JournalEntry& e : read->entries) records.push_back(e.bytes);
  const uint64_t inMesh1 = lod::checkStreamResume(out.string(), kMany.count, records)->meshes[1].file.end - 10;
  test::flipByte(partial, inMesh1);
  std::string differs = refusal(source(), config(), paged());
  EXPECT_NE(differs.find(partial + ": mesh 1's bytes differ from the journal"), std::string::npos) << differs;
  test::flipByte(partial, inMesh1);
  // The journal of a whole-scene `mirage build` to the same output.
  fs::copy_file(journal, dir / "saved");
  {
    auto whole = bake::Journal::open(journal, bake::lodFingerprint(io::generateMany(kMany), config()), kMany.count, 0);
    ASSERT_TRUE(whole.ok() && whole->append(0, std::vector<uint8_t>{1, 2, 3}).ok());
  }
  Status st =
      bake::bakeLodFile(test::world(), source(), out.string(), config(), paged(), {}, nullptr, nullptr, {}, resume);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("journal of another bake"), std::string::npos) << st.error().message;
  fs::rename(dir / "saved", journal);
  EXPECT_EQ(test::fileBytes(partial), partialBytes);

  // Without --resume: the bake runs and, once written, removes the earlier bake's files.
  ASSERT_TRUE(bake::bakeLodFile(test::world(), source(), out.string(), config(), paged(), {}, nullptr, nullptr, {},
                                {journal, false})
                  .ok());
  EXPECT_TRUE(leftBeside(out).empty());
  fs::remove(out);

  // A bake that fails (a mesh cannot be made) removes its journal and files: nothing would resume.
  killedBake(out, paged(), 2);
  lod::MeshSource failing = source();
  failing.mesh = [](uint32_t i) -> Result<Mesh> {
    if (i == 4) return Error{"mesh 4: cannot be made"};
    return io::generateManyMesh(kMany, i);
  };
  Status s =
      bake::bakeLodFile(test::world(), failing, out.string(), config(), paged(), {}, nullptr, nullptr, {}, resume);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("mesh 4: cannot be made"), std::string::npos) << s.error().message;
  EXPECT_TRUE(leftBeside(out).empty());
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

// Collective: rank 0 holds a killed bake's files; every rank resumes it, no rank bakes a resumed mesh,
// every other mesh is baked once, and rank 0 writes the uninterrupted bytes.
TEST(Distributed, StreamBakeResumesOnEveryRank) {
  const bake::World& w = test::world();
  fs::path dir = test::tempDir("stream_ranks"); // each rank names its own; only rank 0's is written
  fs::path out = dir / "out.mrg";
  if (w.root()) {
    EXPECT_TRUE(lod::bakeLodFile(source(), (dir / "whole.mrg").string(), config(), paged()).ok());
    killedBake(out, paged(), 2);
  }
  lod::BuildConfig oneThread = config();
  oneThread.threads = 1;
  bake::ScheduleReport ranks;
  Status s = bake::bakeLodFile(w, source(), out.string(), oneThread, paged(), {.meshesInFlight = 1}, nullptr, &ranks,
                               {}, {bake::journalPath(out.string()), true});
  ASSERT_TRUE(s.ok()) << s.error().message;
  if (w.root()) {
    EXPECT_EQ(test::fileBytes(out), test::fileBytes(dir / "whole.mrg"));
    EXPECT_EQ(ranks.resumedUnits, 2u);
    std::vector<int> baked(kMany.count);
    for (const bake::RankReport& r : ranks.ranks)
      for (uint32_t m : r.units) ++baked[m];
    EXPECT_EQ(baked, (std::vector<int>{0, 0, 1, 1, 1, 1}));
    EXPECT_TRUE(leftBeside(out).empty());
  }
  fs::remove_all(dir);
}
