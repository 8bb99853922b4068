// On-demand pages of a paged .mrg (docs/render.md, "Residency"): openPagedLodAsset reads only the
// indices and root pages, the index's box and vertex-id counts match the DAG, lod::PageStream reads
// every page on its threads equal to readPage, in the order asked for, keeps at most its capacity asked for, runs
// its prepare hook on its threads, and reports a damaged page as one line naming file, chunk and page.
#include <gtest/gtest.h>

#include <any>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>
#include <utility>

#include "lod_meshes.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/page_stream.h"
#include "mirage/lod/paged_asset.h"
#include "test_support.h"

using namespace mirage;

namespace {

std::filesystem::path writePagedBlob(const std::string& name, lod::LodAsset* baked = nullptr) {
  Scene scene;
  scene.source = "generated";
  scene.meshes.push_back(lodtest::makeSeamBlob(4, 3));
  scene.materials.push_back(Material{});
  scene.instances.push_back({0, glm::mat4(1.0f)});
  auto asset = lod::bakeLodAsset(scene, {});
  EXPECT_TRUE(asset.ok());
  lod::LodWriteOptions o;
  o.paged = true;
  o.pages.pageBytes = 16 * 1024;
  auto path = test::tempDir(name) / "paged.mrg";
  Status s = lod::saveLodAsset(path.string(), *asset, o);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  if (baked) *baked = std::move(asset).value();
  return path;
}

// Every page asked for, as many at a time as the stream takes; returns them by page.
std::vector<lod::PageData> streamAll(lod::PageStream& stream, const lod::PagedMesh& mesh, std::string* error) {
  std::vector<lod::PageData> pages(mesh.table.pages.size());
  uint32_t next = 0, got = 0;
  while (got < pages.size()) {
    while (next < pages.size() && stream.request(0, next)) ++next;
    EXPECT_LE(stream.inFlight(), stream.capacity());
    stream.waitForArrival(std::chrono::milliseconds(5000));
    auto arrived = stream.take();
    if (!arrived) {
      *error = arrived.error().message;
      return {};
    }
    for (lod::StreamedPage& p : *arrived) pages[p.page] = std::move(p.data), ++got;
  }
  return pages;
}

} // namespace

TEST(LodPageStream, OpenReadsIndicesAndRootsOnly) {
  lod::LodAsset baked;
  auto path = writePagedBlob("streamopen", &baked);
  auto paged = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(paged.ok()) << paged.error().message;
  ASSERT_EQ(paged->meshes.size(), 1u);
  const lod::PagedMesh& mesh = paged->meshes[0];
  ASSERT_EQ(paged->rootPages[0].size(), mesh.table.rootPageCount);
  // Read: the header, table, scene, meta, index and root pages; not the other pages.
  uint64_t otherPages = 0;
  for (uint32_t p = mesh.table.rootPageCount; p < mesh.blocks.blocks.size(); ++p)
    otherPages += mesh.blocks.blocks[p].storedBytes;
  EXPECT_LE(paged->reader->sourceStats().bytes + otherPages, paged->reader->fileBytes());
  // The index's box and vertex-id counts are those of the DAG the pages reassemble to.
  auto dag = lod::readPagedDag(*paged->reader, mesh);
  ASSERT_TRUE(dag.ok()) << dag.error().message;
  Bounds box;
  for (uint32_t v : dag->clusterVertices) box.add(dag->positions[dag->vertexPosition[v]]);
  EXPECT_EQ(mesh.rest.positionBounds.min, box.min);
  EXPECT_EQ(mesh.rest.positionBounds.max, box.max);
  for (uint32_t p = 0; p < mesh.table.pages.size(); ++p) {
    uint32_t ids = 0;
    for (uint32_t c : mesh.table.clustersOf(p)) ids += dag->clusters[c].vertexCount;
    EXPECT_EQ(mesh.rest.pageClusterVertices[p], ids) << "page " << p;
  }
  auto plainPath = test::tempDir("streamplain") / "plain.mrg";
  ASSERT_TRUE(lod::saveLodAsset(plainPath.string(), baked).ok());
  auto plain = lod::openPagedLodAsset(plainPath.string());
  ASSERT_FALSE(plain.ok());
  EXPECT_NE(plain.error().message.find("paged"), std::string::npos) << plain.error().message;
}

TEST(LodPageStream, StreamsEveryPageAsReadPage) {
  auto path = writePagedBlob("streamall");
  auto paged = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(paged.ok()) << paged.error().message;
  const lod::PagedMesh& mesh = paged->meshes[0];
  ASSERT_GT(mesh.table.pages.size(), 4u);
  lod::PageStream stream(*paged->reader, paged->meshes, {.maxInFlight = 3});
  std::string error;
  std::vector<lod::PageData> pages = streamAll(stream, mesh, &error);
  ASSERT_EQ(error, "");
  uint64_t stored = 0;
  for (uint32_t p = 0; p < pages.size(); ++p) {
    auto direct = lod::readPage(*paged->reader, mesh, p);
    ASSERT_TRUE(direct.ok());
    EXPECT_EQ(pages[p].clusterIds, direct->clusterIds);
    EXPECT_EQ(pages[p].clusterVertices, direct->clusterVertices);
    EXPECT_EQ(pages[p].clusterIndices, direct->clusterIndices);
    EXPECT_EQ(pages[p].positions, direct->positions);
    stored += mesh.blocks.blocks[p].storedBytes;
  }
  EXPECT_EQ(stream.storedBytes(), stored);
  EXPECT_EQ(stream.inFlight(), 0u);
}

// Several threads read at once; the pages still come out in the order asked for (here descending).
TEST(LodPageStream, ThreadsHandPagesOverInTheOrderAsked) {
  auto path = writePagedBlob("streamorder");
  auto paged = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(paged.ok()) << paged.error().message;
  uint32_t count = uint32_t(paged->meshes[0].table.pages.size());
  for (uint32_t threads : {1u, 3u, 8u}) {
    lod::PageStream stream(*paged->reader, paged->meshes, {.maxInFlight = count, .threads = threads});
    for (uint32_t p = count; p-- > 0;) ASSERT_TRUE(stream.request(0, p));
    std::vector<uint32_t> order;
    while (order.size() < count) {
      stream.waitForArrival(std::chrono::milliseconds(5000));
      auto arrived = stream.take();
      ASSERT_TRUE(arrived.ok()) << arrived.error().message;
      for (const lod::StreamedPage& page : *arrived) order.push_back(page.page);
    }
    for (uint32_t i = 0; i < count; ++i) EXPECT_EQ(order[i], count - 1 - i) << threads << " threads";
  }
}

// The prepare hook runs on the reader threads (never the caller's), once per page, before the
// page is handed over with what it made; pages still come in the order asked for.
TEST(LodPageStream, PrepareRunsOnTheReaderThreads) {
  auto path = writePagedBlob("streamprepare");
  auto paged = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(paged.ok()) << paged.error().message;
  const lod::PagedMesh& mesh = paged->meshes[0];
  uint32_t count = uint32_t(mesh.table.pages.size());
  std::thread::id caller = std::this_thread::get_id();
  std::atomic<uint32_t> onCaller{0};
  lod::PageStreamConfig config{.maxInFlight = count, .threads = 3};
  config.prepare = [&](lod::StreamedPage& sp) {
    onCaller += std::this_thread::get_id() == caller;
    sp.prepared = std::pair(sp.page, sp.data.clusterIds.size()); // what the page held
    sp.data = {};
  };
  lod::PageStream stream(*paged->reader, paged->meshes, config);
  for (uint32_t p = 0; p < count; ++p) ASSERT_TRUE(stream.request(0, p));
  std::vector<uint32_t> order;
  while (order.size() < count) {
    stream.waitForArrival(std::chrono::milliseconds(5000));
    auto arrived = stream.take();
    ASSERT_TRUE(arrived.ok()) << arrived.error().message;
    for (const lod::StreamedPage& page : *arrived) {
      auto made = std::any_cast<std::pair<uint32_t, size_t>>(&page.prepared);
      ASSERT_NE(made, nullptr);
      EXPECT_EQ(made->first, page.page);
      EXPECT_EQ(made->second, mesh.table.clustersOf(page.page).size());
      EXPECT_TRUE(page.data.clusterIds.empty()) << "the hook released the decoded page";
      EXPECT_GE(page.prepareSeconds, 0.0);
      order.push_back(page.page);
    }
  }
  for (uint32_t i = 0; i < count; ++i) EXPECT_EQ(order[i], i);
  EXPECT_EQ(onCaller, 0u);
}

TEST(LodPageStream, DamagedPageIsOneLine) {
  auto path = writePagedBlob("streamflip");
  uint64_t at = 0;
  uint32_t page = 0;
  {
    auto paged = lod::openPagedLodAsset(path.string());
    ASSERT_TRUE(paged.ok());
    const lod::PagedMesh& mesh = paged->meshes[0];
    page = uint32_t(mesh.table.pages.size() - 1);
    const asset::BlockInfo& b = mesh.blocks.blocks[page];
    at = paged->reader->chunks()[mesh.chunk].offset + b.offset + b.storedBytes / 2;
  }
  test::flipByte(path, at);
  auto paged = lod::openPagedLodAsset(path.string());
  ASSERT_TRUE(paged.ok()) << "the indices and root pages are intact: " << paged.error().message;
  lod::PageStream stream(*paged->reader, paged->meshes);
  std::string error;
  streamAll(stream, paged->meshes[0], &error);
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("page " + std::to_string(page)), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  EXPECT_FALSE(stream.take().ok()) << "the error stays";
  EXPECT_FALSE(stream.request(0, 0));
}
