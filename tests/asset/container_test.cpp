// AssetWriter/AssetReader: round trips, raw vs zstd storage, alignment, lookups, and the atomic
// write contract (nothing left behind on failure, nothing written outside the path).
#include <atomic>
#include <random>
#include <thread>

#include <csignal>
#include <sys/resource.h>
#include <sys/stat.h>

#include "asset_test_util.h"
#include "mirage/asset/container.h"

using namespace mirage;
using namespace mirage::asset;
using namespace mirage::asset::test;

namespace {} // namespace

TEST(Container, RoundTripsChunksRawAndCompressed) {
  TempDir dir;
  std::string path = dir.file("a.mrg");
  std::vector<uint8_t> text(5000);
  for (size_t i = 0; i < text.size(); ++i) text[i] = uint8_t("mirage "[i % 7]);
  std::vector<uint8_t> noise = randomBytes(777, 1);
  std::vector<uint8_t> small{1, 2, 3};

  AssetWriter w;
  w.addChunk(chunk::Meta, text);
  w.addChunk(chunk::ClusterDag, noise, 19);
  w.addChunk(chunk::Surfels, {});
  w.addChunk(chunk::Visibility, small, 0);
  w.addChunk(FourCC("XTRA"), text, 0);
  ASSERT_TRUE(w.write(path).ok());

  Result<AssetReader> r = AssetReader::open(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->chunks().size(), 5u);
  const auto& c = r->chunks();
  EXPECT_TRUE(c[0].compressed); // repetitive text compresses
  EXPECT_EQ(c[0].zstdLevel, kDefaultZstdLevel);
  EXPECT_LT(c[0].storedBytes, text.size());
  EXPECT_FALSE(c[1].compressed); // noise does not: stored raw
  EXPECT_EQ(c[1].zstdLevel, 0);
  EXPECT_FALSE(c[3].compressed);
  EXPECT_FALSE(c[4].compressed); // level 0 forces raw
  for (const ChunkInfo& info : c) EXPECT_EQ(info.offset % kPayloadAlignment, 0u);
  EXPECT_EQ(r->fileBytes(), std::filesystem::file_size(path));

  EXPECT_EQ(*r->readChunk(0), text);
  EXPECT_EQ(*r->readChunk(chunk::ClusterDag), noise);
  EXPECT_TRUE(r->readChunk(chunk::Surfels)->empty());
  EXPECT_EQ(*r->readChunk(chunk::Visibility), small);
  EXPECT_EQ(*r->readChunk(FourCC("XTRA")), text);
  EXPECT_EQ(r->find(chunk::Surfels), std::optional<size_t>(2));
  EXPECT_FALSE(r->find(chunk::Scene).has_value());
}

TEST(Container, MissingChunkAndBadIndexAreErrors) {
  TempDir dir;
  std::string path = dir.file("b.mrg");
  AssetWriter w;
  ASSERT_TRUE(w.write(path).ok()); // an empty container is valid
  Result<AssetReader> r = AssetReader::open(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->chunks().empty());
  Result<std::vector<uint8_t>> missing = r->readChunk(chunk::Scene);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().message, path + ": no 'SCEN' chunk");
  EXPECT_FALSE(r->readChunk(size_t(3)).ok());
}

TEST(Container, FourCCPrintsReadably) {
  EXPECT_EQ(chunk::Visibility.str(), "'PVS '");
  EXPECT_EQ(FourCC(0x0a41u).str(), "'A\\x0a\\x00\\x00'");
  EXPECT_EQ(chunk::Scene.code, 0x4e454353u); // 'S' in the low byte
}

TEST(Container, ReaderIsMovableAndReadsFromThreads) {
  TempDir dir;
  std::string path = dir.file("c.mrg");
  std::vector<uint8_t> data = randomBytes(4096, 2);
  AssetWriter w;
  w.addChunk(chunk::Mesh, data);
  ASSERT_TRUE(w.write(path).ok());
  Result<AssetReader> r = AssetReader::open(path);
  ASSERT_TRUE(r.ok());
  AssetReader moved = std::move(*r);
  std::vector<std::thread> threads;
  std::atomic<int> good{0};
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&] {
      for (int i = 0; i < 20; ++i) good += moved.readChunk(size_t(0)).ok() ? 1 : 0;
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(good.load(), 80);
}

TEST(AtomicWrite, MissingFolderFailsAndLeavesNothing) {
  TempDir dir;
  std::string path = dir.file("no/such/folder/x.mrg");
  AssetWriter w;
  w.addChunk(chunk::Meta, std::vector<uint8_t>{1, 2, 3});
  Status st = w.write(path);
  ASSERT_FALSE(st.ok());
  expectOneLineError(st.error().message, path);
  EXPECT_TRUE(dir.list().empty());
}

TEST(AtomicWrite, FailedRenameRemovesTempFile) {
  TempDir dir;
  // The output path is an existing non-empty folder: the temp file is written, the rename fails.
  std::string path = dir.file("taken");
  std::filesystem::create_directories(path + "/inside");
  AssetWriter w;
  w.addChunk(chunk::Meta, std::vector<uint8_t>(100, 7));
  Status st = w.write(path);
  ASSERT_FALSE(st.ok());
  expectOneLineError(st.error().message, path);
  EXPECT_EQ(dir.list(), std::vector<std::string>{"taken"});
}

TEST(AtomicWrite, OverwritesAndReplacesSymlinkInsteadOfFollowing) {
  TempDir dir;
  std::string path = dir.file("out.mrg");
  std::string victim = dir.file("victim.txt");
  writeBytes(victim, {'k', 'e', 'e', 'p'});
  std::filesystem::create_symlink(victim, path);
  for (uint8_t round = 0; round < 2; ++round) {
    AssetWriter w;
    w.addChunk(chunk::Meta, std::vector<uint8_t>(10, round));
    ASSERT_TRUE(w.write(path).ok());
    Result<AssetReader> r = AssetReader::open(path);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(*r->readChunk(chunk::Meta), std::vector<uint8_t>(10, round));
  }
  EXPECT_FALSE(std::filesystem::is_symlink(path));
  EXPECT_EQ(readBytes(victim), (std::vector<uint8_t>{'k', 'e', 'e', 'p'}));
  EXPECT_EQ(dir.list(), (std::vector<std::string>{"out.mrg", "victim.txt"}));
}

TEST(AtomicWrite, OpenRejectsNonFilesAndMissingFiles) {
  TempDir dir;
  Result<AssetReader> a = AssetReader::open(dir.file("absent.mrg"));
  ASSERT_FALSE(a.ok());
  expectOneLineError(a.error().message, dir.file("absent.mrg"));
  Result<AssetReader> b = AssetReader::open(dir.path().string());
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("not a regular file"), std::string::npos);
}

TEST(AtomicWrite, FailureMidWriteRemovesTempFile) {
  TempDir dir;
  std::string path = dir.file("big.mrg");
  AssetWriter w;
  w.addChunk(chunk::Mesh, randomBytes(64 * 1024, 3), 0);
  // A file size limit makes write(2) fail with EFBIG part way through (SIGXFSZ ignored so it is
  // an error, not a kill); the limit is restored before anything else writes files.
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  Status st = w.write(path);
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, oldHandler);
  ASSERT_FALSE(st.ok());
  expectOneLineError(st.error().message, path);
  EXPECT_NE(st.error().message.find("write failed"), std::string::npos) << st.error().message;
  EXPECT_TRUE(dir.list().empty());
}

TEST(AtomicWrite, OpenOfFifoFailsWithoutBlocking) {
  TempDir dir;
  std::string path = dir.file("pipe.mrg");
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
  Result<AssetReader> r = AssetReader::open(path); // must not wait for a writer
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not a regular file"), std::string::npos);
}

TEST(Container, EmptyChunksAnywhere) {
  TempDir dir;
  std::string path = dir.file("e.mrg");
  // Empty chunks share their offset with the next payload (or sit at the end of the file).
  for (int layout = 0; layout < 4; ++layout) {
    AssetWriter w;
    std::vector<uint8_t> data = randomBytes(33, 4);
    for (int i = 0; i < 6; ++i) {
      bool empty = (layout >> (i % 2)) & 1 || i == 5;
      w.addChunk(chunk::Surfels, empty ? std::vector<uint8_t>{} : data, i % 3);
    }
    ASSERT_TRUE(w.write(path).ok());
    Result<AssetReader> r = AssetReader::open(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    for (size_t i = 0; i < r->chunks().size(); ++i) EXPECT_TRUE(r->readChunk(i).ok()) << i;
  }
}
