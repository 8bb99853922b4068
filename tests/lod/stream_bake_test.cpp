// The streaming bake (lod/stream_bake.h): meshes made on demand, a bounded number baked at once, each
// chunk written as its turn comes. The file holds the chunks saveLodAsset writes for the same scene,
// its bytes do not depend on threads, meshes in flight or the order meshes finish in, the counters
// the memory bound rests on stay within their limits, a failing mesh leaves nothing behind, and a
// residency reader of the file reads only indices and root pages; meshes baked elsewhere (remote
// bakers) keep the bytes; a resumable bake stopped mid-way continues to the same bytes, and refuses
// files that do not match its records and damaged records.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <optional>
#include <thread>

#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/lod/stream_bake.h"
#include "test_support.h"

using namespace mirage;

namespace {

io::ManyOptions smallMany() {
  io::ManyOptions o;
  o.count = 6;
  o.triangles = 3000;
  o.seed = 7;
  return o;
}

lod::MeshSource manySource(const io::ManyOptions& o) {
  lod::MeshSource s;
  s.layout = io::generateManyLayout(o);
  s.mesh = [o](uint32_t i) -> Result<Mesh> { return io::generateManyMesh(o, i); };
  return s;
}

lod::LodWriteOptions paged() {
  lod::LodWriteOptions w;
  w.paged = true;
  w.pages.pageBytes = 16 * 1024; // several pages per mesh
  return w;
}

std::string bakeFile(const std::filesystem::path& path, const lod::MeshSource& source, const lod::LodWriteOptions& w,
                     uint32_t threads, lod::StreamBakeOptions options, lod::StreamBakeReport* report = nullptr) {
  lod::BuildConfig config;
  config.threads = threads;
  Status s = lod::bakeLodFile(source, path.string(), config, w, options, report);
  return s.ok() ? "" : s.error().message;
}

// Every chunk of `streamed` holds what the same-type chunk of `whole` holds: mesh chunks as stored
// (so the same pages and blocks), the others decompressed.
void expectSameChunks(const std::string& streamed, const std::string& whole) {
  auto a = asset::AssetReader::open(streamed), b = asset::AssetReader::open(whole);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->chunks().size(), b->chunks().size());
  for (asset::FourCC type : {asset::chunk::ClusterPages, asset::chunk::ClusterDag}) {
    std::vector<size_t> ia, ib;
    for (size_t i = 0; i < a->chunks().size(); ++i) {
      if (a->chunks()[i].type == type) ia.push_back(i);
      if (b->chunks()[i].type == type) ib.push_back(i);
    }
    ASSERT_EQ(ia.size(), ib.size());
    for (size_t k = 0; k < ia.size(); ++k)
      EXPECT_EQ(a->readStoredChunk(ia[k]).value(), b->readStoredChunk(ib[k]).value()) << "mesh " << k;
  }
  for (asset::FourCC type : {asset::chunk::SourceMap, asset::chunk::Scene, asset::chunk::Meta}) {
    auto x = a->readChunk(type), y = b->readChunk(type);
    ASSERT_TRUE(x.ok() && y.ok()) << type.str();
    EXPECT_TRUE(*x == *y) << type.str();
  }
}

} // namespace

TEST(StreamBake, SameChunksAsTheWholeAssetWriter) {
  auto dir = test::tempDir("stream_bake_same");
  io::ManyOptions o = smallMany();
  auto baked = lod::bakeLodAsset(io::generateMany(o), {});
  ASSERT_TRUE(baked.ok());
  for (bool isPaged : {true, false}) {
    lod::LodWriteOptions w = isPaged ? paged() : lod::LodWriteOptions{};
    std::string name = isPaged ? "paged" : "flat";
    ASSERT_TRUE(lod::saveLodAsset((dir / (name + "_whole.mrg")).string(), *baked, w).ok());
    ASSERT_EQ(bakeFile(dir / (name + "_streamed.mrg"), manySource(o), w, 2, {}), "");
    expectSameChunks((dir / (name + "_streamed.mrg")).string(), (dir / (name + "_whole.mrg")).string());
    // And it loads as the same asset (the scene chunk after the meshes changes nothing for readers).
    auto loaded = lod::loadLodAsset((dir / (name + "_streamed.mrg")).string());
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    EXPECT_EQ(loaded->dags.size(), o.count);
    EXPECT_EQ(loaded->sourceClusters, baked->sourceClusters);
  }
}

// Threads, meshes in flight, the window and the order meshes finish in (mesh 0 made last) leave the
// bytes unchanged; the counters stay within their bounds, and no mesh is made more than the window
// ahead of the writer (seen by the source itself, against the progress callback).
TEST(StreamBake, BytesDoNotDependOnThreadsOrOrderAndMemoryStaysBounded) {
  auto dir = test::tempDir("stream_bake_threads");
  // Meshes large enough that concurrent bakes partition at the same time (METIS's shared state).
  io::ManyOptions o = smallMany();
  o.count = 8;
  o.triangles = 8000; // n = 20
  ASSERT_EQ(bakeFile(dir / "one.mrg", manySource(o), paged(), 1, {.meshesInFlight = 1, .reorderWindow = 1}), "");
  std::vector<uint8_t> reference = test::fileBytes(dir / "one.mrg");
  ASSERT_FALSE(reference.empty());
  struct Run {
    uint32_t threads, inFlight, window;
  };
  // Two threads per mesh; one each, two and four at once; more workers than threads.
  for (Run run : {Run{2, 1, 0}, Run{2, 2, 0}, Run{2, 4, 4}, Run{1, 3, 5}}) {
    std::atomic<uint32_t> written{0}, live{0}, peakLive{0}, aheadViolations{0};
    lod::MeshSource source = manySource(o);
    uint32_t window = std::max(run.inFlight, run.window ? run.window : 2 * run.inFlight);
    source.mesh = [&, o](uint32_t i) -> Result<Mesh> {
      if (i >= written.load() + window) ++aheadViolations;
      uint32_t now = ++live;
      for (uint32_t p = peakLive.load(); now > p && !peakLive.compare_exchange_weak(p, now);) {
      }
      if (i == 0) std::this_thread::sleep_for(std::chrono::milliseconds(50)); // the others finish first
      Mesh m = io::generateManyMesh(o, i);
      --live;
      return m;
    };
    lod::StreamBakeReport report;
    lod::BuildConfig config;
    config.threads = run.threads;
    Status s = lod::bakeLodFile(source, (dir / "many.mrg").string(), config, paged(),
                                {.meshesInFlight = run.inFlight, .reorderWindow = run.window}, &report,
                                [&](size_t done, size_t, uint64_t, uint64_t) { written = uint32_t(done); });
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_EQ(test::fileBytes(dir / "many.mrg"), reference)
        << run.threads << " threads, " << run.inFlight << " in flight";
    EXPECT_EQ(report.meshesInFlight, run.inFlight);
    EXPECT_EQ(report.reorderWindow, window);
    EXPECT_LE(report.peakMeshesInFlight, run.inFlight);
    EXPECT_LE(report.peakMeshesWaiting, window);
    EXPECT_LE(peakLive.load(), run.inFlight);
    EXPECT_EQ(aheadViolations.load(), 0u);
    EXPECT_EQ(report.meshes, o.count);
    EXPECT_EQ(report.inputTriangles, uint64_t(o.count) * 20 * 20 * 20);
  }
}

TEST(StreamBake, AFailingMeshLeavesNothing) {
  auto dir = test::tempDir("stream_bake_fail");
  lod::MeshSource source = manySource(smallMany());
  source.mesh = [o = smallMany()](uint32_t i) -> Result<Mesh> {
    if (i == 3) return Error{"mesh 3: cannot be made"};
    return io::generateManyMesh(o, i);
  };
  std::string message = bakeFile(dir / "x.mrg", source, paged(), 2, {.meshesInFlight = 2});
  EXPECT_NE(message.find("mesh 3: cannot be made"), std::string::npos) << message;
  EXPECT_TRUE(std::filesystem::is_empty(dir)) << "output, temp or spool file left";
}

// Remote bakers (what bake::bakeLodFile makes of other MPI ranks): a fake one bakes the meshes it
// takes on its own thread with bakeStreamMesh and delivers them late and out of order. Flat and paged
// files keep the one-process bytes; every mesh is baked once, here or there; a remote error stops
// the bake and leaves nothing.
TEST(StreamBake, RemoteBakersKeepTheBytes) {
  auto dir = test::tempDir("stream_bake_remote");
  io::ManyOptions o = smallMany();
  lod::MeshSource source = manySource(o);
  for (bool isPaged : {true, false}) {
    lod::LodWriteOptions w = isPaged ? paged() : lod::LodWriteOptions{};
    ASSERT_EQ(bakeFile(dir / "one.mrg", source, w, 1, {.meshesInFlight = 1}), "");
    std::vector<uint8_t> reference = test::fileBytes(dir / "one.mrg");
    lod::BuildConfig config;
    config.threads = 1;
    // The remote side: up to three meshes at once, each finished after the one taken after it.
    std::vector<std::pair<uint32_t, Result<std::vector<uint8_t>>>> held;
    std::vector<uint32_t> remoteMeshes;
    lod::RemoteMeshBakers remote{
        [&](const lod::RemoteMeshBakers::Take& take, const lod::RemoteMeshBakers::Deliver& deliver) {
          while (held.size() < 3) {
            std::optional<uint32_t> mesh = take();
            if (!mesh) break;
            remoteMeshes.push_back(*mesh);
            held.emplace_back(*mesh, lod::bakeStreamMesh(source, *mesh, config, w, (dir / "two.mrg").string()));
          }
          if (!held.empty()) {
            deliver(held.back().first, std::move(held.back().second));
            held.pop_back();
          }
        }};
    std::vector<uint32_t> localMeshes;
    Status s = lod::bakeLodFile(source, (dir / "two.mrg").string(), config, w, {.meshesInFlight = 1}, nullptr, {},
                                &remote, &localMeshes);
    ASSERT_TRUE(s.ok()) << s.error().message;
    EXPECT_EQ(test::fileBytes(dir / "two.mrg"), reference) << (isPaged ? "paged" : "flat");
    EXPECT_FALSE(remoteMeshes.empty());
    std::vector<uint32_t> all = localMeshes;
    all.insert(all.end(), remoteMeshes.begin(), remoteMeshes.end());
    std::sort(all.begin(), all.end());
    std::vector<uint32_t> each(o.count);
    std::iota(each.begin(), each.end(), 0u);
    EXPECT_EQ(all, each);
  }
  std::filesystem::remove(dir / "one.mrg");
  std::filesystem::remove(dir / "two.mrg");
  lod::RemoteMeshBakers failing{
      [](const lod::RemoteMeshBakers::Take& take, const lod::RemoteMeshBakers::Deliver& deliver) {
        if (std::optional<uint32_t> mesh = take()) deliver(*mesh, Error{"rank 1: mesh cannot be baked"});
      }};
  lod::BuildConfig config;
  Status s =
      lod::bakeLodFile(source, (dir / "x.mrg").string(), config, paged(), {.meshesInFlight = 1}, nullptr, {}, &failing);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("rank 1: mesh cannot be baked"), std::string::npos) << s.error().message;
  EXPECT_TRUE(std::filesystem::is_empty(dir)) << "output, temp or spool file left";
}

namespace {

// A resumable bake of `source` into `path` that continues `records` (checked first) and keeps the
// new records; with `stopAt`, it stops when mesh stopAt is written (its bytes durable, its record
// not kept, or kept with `recordLast`), as a process killed there leaves it. Returns "" or the error.
std::string bakeResumable(const std::filesystem::path& path, const lod::MeshSource& source,
                          const lod::LodWriteOptions& w, std::vector<std::vector<uint8_t>>& records,
                          std::optional<uint32_t> stopAt, lod::StreamBakeReport* report = nullptr,
                          std::vector<uint32_t>* localMeshes = nullptr, bool recordLast = false) {
  auto resume = lod::checkStreamResume(path.string(), uint32_t(source.layout.meshes.size()), records);
  if (!resume) return resume.error().message;
  lod::StreamJournal journal{std::move(resume).value(), [&](uint32_t mesh, std::span<const uint8_t> record) -> Status {
                               if (mesh == stopAt && !recordLast) return Error{"stopped"};
                               EXPECT_EQ(mesh, records.size());
                               records.emplace_back(record.begin(), record.end());
                               return mesh == stopAt ? Status(Error{"stopped"}) : Status(Ok{});
                             }};
  lod::BuildConfig config;
  config.threads = 2;
  Status s = lod::bakeLodFile(source, path.string(), config, w, {.meshesInFlight = 2}, report, {}, nullptr, localMeshes,
                              &journal);
  return s.ok() ? "" : s.error().message;
}

void appendBytes(const std::filesystem::path& p, size_t n) { // what a process killed mid-write leaves
  std::ofstream(p, std::ios::binary | std::ios::app) << std::string(n, '\x5a');
}

} // namespace

// A resumable bake stopped after K meshes (the meshes after K baked or in flight, mesh K's bytes
// written but not recorded, then bytes of a half-written mesh) continues, twice, to the bytes of an
// uninterrupted bake, flat and paged; the continued bake makes no mesh it resumed, and leaves only the
// output behind.
TEST(StreamBake, ResumedAfterStopsToTheSameBytes) {
  auto dir = test::tempDir("stream_bake_resume");
  io::ManyOptions o = smallMany();
  for (bool isPaged : {true, false}) {
    lod::LodWriteOptions w = isPaged ? paged() : lod::LodWriteOptions{};
    SCOPED_TRACE(isPaged ? "paged" : "flat");
    ASSERT_EQ(bakeFile(dir / "whole.mrg", manySource(o), w, 1, {.meshesInFlight = 1}), "");
    const auto path = dir / "out.mrg";
    std::vector<std::vector<uint8_t>> records;
    EXPECT_EQ(bakeResumable(path, manySource(o), w, records, 2), "stopped");
    ASSERT_EQ(records.size(), 2u);
    EXPECT_FALSE(std::filesystem::exists(path));
    ASSERT_TRUE(std::filesystem::exists(lod::streamPartialPath(path.string())));
    appendBytes(lod::streamPartialPath(path.string()), 3000);
    appendBytes(lod::streamSpoolPath(path.string()), 17);
    EXPECT_EQ(bakeResumable(path, manySource(o), w, records, 4), "stopped");
    ASSERT_EQ(records.size(), 4u);

    std::atomic<uint32_t> lowestMade{~0u};
    lod::MeshSource source = manySource(o);
    source.mesh = [&, o](uint32_t i) -> Result<Mesh> {
      for (uint32_t l = lowestMade.load(); i < l && !lowestMade.compare_exchange_weak(l, i);) {
      }
      return io::generateManyMesh(o, i);
    };
    lod::StreamBakeReport report;
    std::vector<uint32_t> local;
    ASSERT_EQ(bakeResumable(path, source, w, records, std::nullopt, &report, &local), "");
    EXPECT_EQ(test::fileBytes(path), test::fileBytes(dir / "whole.mrg"));
    EXPECT_EQ(records.size(), o.count);
    EXPECT_EQ(report.resumedMeshes, 4u);
    EXPECT_EQ(lowestMade.load(), 4u);
    EXPECT_EQ(local.size(), o.count - 4);
    EXPECT_EQ(report.meshes, o.count);
    EXPECT_EQ(report.inputTriangles, uint64_t(o.count) * 12 * 12 * 20); // every mesh of the file
    std::filesystem::remove(dir / "whole.mrg");
    std::filesystem::remove(path);
    EXPECT_TRUE(std::filesystem::is_empty(dir)) << "partial output or spool left";
  }
}

// Stopped after every mesh was recorded (killed while writing the last chunks): the continued bake
// makes no mesh, only the TMAP, SCEN and META chunks, and writes the uninterrupted bytes.
TEST(StreamBake, ResumedWithEveryMeshRecorded) {
  auto dir = test::tempDir("stream_bake_resume_all");
  io::ManyOptions o = smallMany();
  ASSERT_EQ(bakeFile(dir / "whole.mrg", manySource(o), paged(), 1, {.meshesInFlight = 1}), "");
  const auto path = dir / "out.mrg";
  std::vector<std::vector<uint8_t>> records;
  EXPECT_EQ(bakeResumable(path, manySource(o), paged(), records, o.count - 1, nullptr, nullptr, true), "stopped");
  ASSERT_EQ(records.size(), o.count);
  appendBytes(lod::streamPartialPath(path.string()), 500); // a TMAP chunk cut short
  lod::MeshSource none = manySource(o);
  none.mesh = [](uint32_t i) -> Result<Mesh> { return Error{"mesh " + std::to_string(i) + " made again"}; };
  lod::StreamBakeReport report;
  ASSERT_EQ(bakeResumable(path, none, paged(), records, std::nullopt, &report), "");
  EXPECT_EQ(report.resumedMeshes, o.count);
  EXPECT_EQ(test::fileBytes(path), test::fileBytes(dir / "whole.mrg"));
  std::filesystem::remove(dir / "whole.mrg");
  std::filesystem::remove(path);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// What does not match the records is refused with one line naming the file and the mesh, and
// nothing is changed: a byte of the partial output or spool flipped, a file missing, a record cut
// short. A bake that fails keeps its files for its owner (bake::bakeLodFile removes them).
TEST(StreamBake, ResumeRefusesWhatDoesNotMatchItsRecords) {
  auto dir = test::tempDir("stream_bake_resume_damaged");
  io::ManyOptions o = smallMany();
  const auto path = dir / "out.mrg";
  const std::string partial = lod::streamPartialPath(path.string()), spool = lod::streamSpoolPath(path.string());
  std::vector<std::vector<uint8_t>> records;
  EXPECT_EQ(bakeResumable(path, manySource(o), paged(), records, 3), "stopped");
  ASSERT_EQ(records.size(), 3u);
  auto refused = [&](const std::vector<std::vector<uint8_t>>& r) {
    auto resume = lod::checkStreamResume(path.string(), o.count, r);
    return resume ? std::string() : resume.error().message;
  };
  EXPECT_EQ(refused(records), "");
  const std::vector<uint8_t> partialBytes = test::fileBytes(partial), spoolBytes = test::fileBytes(spool);
  uint64_t mesh1 = lod::checkStreamResume(path.string(), o.count, records)->meshes[1].file.end - 10; // its chunk
  test::flipByte(partial, mesh1);
  std::string message = refused(records);
  EXPECT_NE(message.find(partial + ": mesh 1's bytes differ from the journal"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos);
  test::flipByte(partial, mesh1);
  uint64_t map2 = lod::checkStreamResume(path.string(), o.count, records)->meshes[2].spool.end - 1; // its TMAP
  test::flipByte(spool, map2);
  message = refused(records);
  EXPECT_NE(message.find(spool + ": mesh 2's bytes differ"), std::string::npos) << message;
  test::flipByte(spool, map2);
  EXPECT_EQ(test::fileBytes(partial), partialBytes); // checking changed nothing
  EXPECT_EQ(test::fileBytes(spool), spoolBytes);

  std::vector<std::vector<uint8_t>> cut = records;
  cut[1].pop_back();
  message = refused(cut);
  EXPECT_NE(message.find("damaged bake journal"), std::string::npos) << message;
  std::filesystem::rename(partial, dir / "kept");
  message = refused(records);
  EXPECT_NE(message.find(partial + ": missing"), std::string::npos) << message;
  std::filesystem::rename(dir / "kept", partial);
  EXPECT_EQ(refused({}), ""); // no records: a new bake, whatever is there

  // A mesh that cannot be made stops the bake; the files stay for the journal's owner.
  lod::MeshSource failing = manySource(o);
  failing.mesh = [o](uint32_t i) -> Result<Mesh> {
    if (i == 4) return Error{"mesh 4: cannot be made"};
    return io::generateManyMesh(o, i);
  };
  message = bakeResumable(path, failing, paged(), records, std::nullopt);
  EXPECT_NE(message.find("mesh 4: cannot be made"), std::string::npos) << message;
  EXPECT_TRUE(std::filesystem::exists(partial) && std::filesystem::exists(spool));
  lod::removeStreamFiles(path.string());
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// Damaged records are refused with one line, never a crash: statistics (a record's last field, a
// varint length and CBOR) nesting 200000 deep, on which nlohmann's CBOR reader recursed off the
// stack, or announcing 2^60 elements, on which it threw; a chunk offset and size both moved by 2^63,
// whose sum wraps to the mesh's recorded end.
TEST(StreamBake, ResumeRefusesDamagedRecords) {
  auto dir = test::tempDir("stream_bake_resume_records");
  io::ManyOptions o = smallMany();
  o.count = 3;
  o.triangles = 500;
  const auto path = dir / "out.mrg";
  std::vector<std::vector<uint8_t>> records;
  EXPECT_EQ(bakeResumable(path, manySource(o), lod::LodWriteOptions{}, records, 2), "stopped");
  ASSERT_EQ(records.size(), 2u);
  auto checked = lod::checkStreamResume(path.string(), o.count, records);
  ASSERT_TRUE(checked.ok()) << checked.error().message;
  auto refused = [&](const std::vector<std::vector<uint8_t>>& r) {
    auto resume = lod::checkStreamResume(path.string(), o.count, r);
    if (resume) return std::string();
    EXPECT_EQ(resume.error().message.find('\n'), std::string::npos);
    return resume.error().message;
  };

  const size_t statsBytes = checked->meshes[1].stats.size();
  asset::ByteWriter statsLength;
  statsLength.writeVarint(statsBytes);
  std::vector<uint8_t> deep(200000, 0x81); // arrays of one element, nested
  deep.push_back(0);
  const std::vector<uint8_t> huge = {0x9b, 0x0f, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff}; // an array of 2^60 - 1
  for (const std::vector<uint8_t>& stats : {deep, huge}) {
    std::vector<std::vector<uint8_t>> damaged = records;
    damaged[1].resize(damaged[1].size() - statsBytes - statsLength.size());
    asset::ByteWriter w;
    w.writeArray(std::span<const uint8_t>(stats));
    damaged[1].insert(damaged[1].end(), w.data().begin(), w.data().end());
    std::string message = refused(damaged);
    EXPECT_NE(message.find("mesh 1: mesh statistics do not decode"), std::string::npos) << message;
  }
  std::vector<std::vector<uint8_t>> wrapped = records; // the chunk entry comes first
  for (size_t field : {offsetof(asset::ChunkEntry, offset), offsetof(asset::ChunkEntry, storedBytes)})
    wrapped[1][field + 7] ^= 0x80;
  std::string message = refused(wrapped);
  EXPECT_NE(message.find("mesh 1 does not follow the one before"), std::string::npos) << message;
  lod::removeStreamFiles(path.string());
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// A residency reader (openPagedLodAsset) reads the container's table, the scene and META chunks,
// every mesh's index and its root pages: no other page.
TEST(StreamBake, ResidencyOpenReadsOnlyIndicesAndRootPages) {
  auto dir = test::tempDir("stream_bake_open");
  auto path = dir / "many.mrg";
  ASSERT_EQ(bakeFile(path, manySource(smallMany()), paged(), 2, {}), "");
  auto opened = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  uint64_t expected = sizeof(asset::FileHeader) + opened->reader->chunks().size() * sizeof(asset::ChunkEntry);
  uint64_t allPages = 0, rootPages = 0;
  for (const asset::ChunkInfo& c : opened->reader->chunks())
    if (c.type == asset::chunk::Scene || c.type == asset::chunk::Meta) expected += c.storedBytes;
  for (const lod::PagedMesh& m : opened->meshes) {
    expected += m.blocks.indexBytes;
    for (uint32_t p = 0; p < m.blocks.blocks.size(); ++p) {
      allPages += m.blocks.blocks[p].storedBytes;
      if (p < m.table.rootPageCount) expected += m.blocks.blocks[p].storedBytes, ++rootPages;
    }
  }
  uint64_t received = opened->reader->sourceStats().bytes;
  EXPECT_LE(received, expected + 64 * opened->meshes.size()) << "read beyond indices and root pages";
  EXPECT_LT(received, allPages / 2);
  EXPECT_EQ(rootPages, opened->meshes.size());
}
