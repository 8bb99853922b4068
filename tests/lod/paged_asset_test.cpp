// The paged cluster DAG in a .mrg ('CPAG', docs/lod.md "Paged chunk"): written by saveLodAsset,
// read page by page through the container's block reads, every page equal to the page the layout
// made, the reassembled DAG equal to the CDAG decoder's, and damaged files rejected with the file,
// chunk and page named.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "lod_meshes.h"
#include "mirage/asset/container.h"
#include "mirage/io/import.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/lod/verify.h"
#include "test_support.h"

using namespace mirage;

namespace {

// Two meshes (closed with UV charts, open terrain), small pages so each mesh spans many.
lod::LodAsset bakeTwoMeshes() {
  Scene scene;
  scene.source = "generated";
  scene.meshes.push_back(lodtest::makeSeamBlob(4, 3));
  scene.meshes.push_back(lodtest::makeTerrain(60, 2));
  scene.materials.push_back(Material{});
  scene.instances.push_back({0, glm::mat4(1.0f)});
  scene.instances.push_back({1, glm::mat4(1.0f)});
  auto baked = lod::bakeLodAsset(scene, {});
  EXPECT_TRUE(baked.ok()) << (baked.ok() ? "" : baked.error().message);
  return baked.ok() ? std::move(baked).value() : lod::LodAsset{};
}

lod::LodWriteOptions pagedOptions() {
  lod::LodWriteOptions o;
  o.paged = true;
  o.pages.pageBytes = 16 * 1024;
  return o;
}

struct PagedFile {
  std::filesystem::path path;
  lod::LodAsset asset;
};

PagedFile writePaged(const std::string& name) {
  PagedFile f{test::tempDir(name) / "paged.mrg", bakeTwoMeshes()};
  Status s = lod::saveLodAsset(f.path.string(), f.asset, pagedOptions());
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return f;
}

bool mentions(const std::string& message, const std::string& what) { return message.find(what) != std::string::npos; }

} // namespace

// Each page read on its own (in reverse order: no page needs another to decode) equals the page the
// layout made, and the reassembled DAGs equal the CDAG decoder's (up to vertex numbering), also
// through loadLodAsset.
TEST(LodPagedAsset, ReadPageByPageEqualsTheDag) {
  PagedFile f = writePaged("pagedread");
  auto reader = asset::AssetReader::open(f.path.string());
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  EXPECT_FALSE(reader->find(asset::chunk::ClusterDag)) << "a paged file holds no CDAG chunk";
  auto meshes = lod::openPagedMeshes(*reader);
  ASSERT_TRUE(meshes.ok()) << meshes.error().message;
  ASSERT_EQ(meshes->size(), f.asset.dags.size());
  for (size_t m = 0; m < meshes->size(); ++m) {
    const lod::PagedMesh& mesh = (*meshes)[m];
    const lod::ClusterDag& built = f.asset.dags[m];
    lod::PagedDag expected = lod::buildPages(built, lod::PageConfig{16 * 1024, 16});
    ASSERT_EQ(mesh.table.pages.size(), expected.pages.size());
    EXPECT_GT(mesh.table.pages.size(), 4u) << "mesh " << m << " should span several pages";
    EXPECT_EQ(mesh.table.pageClusters, expected.table.pageClusters);
    EXPECT_EQ(mesh.table.dependencies, expected.table.dependencies);
    EXPECT_EQ(mesh.blocks.blocks.size(), mesh.table.pages.size());
    std::vector<lod::PageData> pages(mesh.table.pages.size());
    for (uint32_t p = uint32_t(pages.size()); p-- > 0;) {
      auto page = lod::readPage(*reader, mesh, p);
      ASSERT_TRUE(page.ok()) << page.error().message;
      auto want = lod::decodePage(expected.pages[p], expected.table, p, "expected");
      ASSERT_TRUE(want.ok()) << want.error().message;
      EXPECT_EQ(page->clusterIds, want->clusterIds);
      EXPECT_EQ(page->clusterVertices, want->clusterVertices);
      EXPECT_EQ(page->clusterIndices, want->clusterIndices);
      ASSERT_EQ(page->positions.size(), want->positions.size());
      EXPECT_EQ(std::memcmp(page->positions.data(), want->positions.data(), page->positions.size() * 12), 0);
      EXPECT_EQ(page->normals, want->normals);
      EXPECT_EQ(page->uv0, want->uv0);
      pages[p] = std::move(page).value();
    }
    auto reference = lod::decodeDag(lod::encodeDag(built), "reference");
    ASSERT_TRUE(reference.ok()) << reference.error().message;
    auto dag = lod::reassemblePagedDag(mesh.table, mesh.rest, pages, "paged.mrg");
    ASSERT_TRUE(dag.ok()) << dag.error().message;
    EXPECT_EQ(lod::dagDifference(*dag, *reference), "") << "mesh " << m;
    EXPECT_EQ(dag->positions.size(), reference->positions.size()) << "welding recovered exactly";
    EXPECT_TRUE(lod::verifyDag(*dag).ok()) << "mesh " << m;
  }
  auto loaded = lod::loadLodAsset(f.path.string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_EQ(loaded->dags.size(), f.asset.dags.size());
  EXPECT_EQ(loaded->sourceClusters, f.asset.sourceClusters);
  for (size_t m = 0; m < loaded->dags.size(); ++m) {
    auto reference = lod::decodeDag(lod::encodeDag(f.asset.dags[m]), "reference");
    ASSERT_TRUE(reference.ok());
    EXPECT_EQ(lod::dagDifference(loaded->dags[m], *reference), "") << "mesh " << m;
  }
  // The difference check is not vacuous.
  lod::ClusterDag moved = loaded->dags[0];
  moved.positions[moved.vertexPosition[moved.clusterVertices[0]]].x += 1.0f;
  EXPECT_NE(lod::dagDifference(moved, loaded->dags[0]), "");
}

// A flipped byte inside one page: that page is rejected naming the file, the chunk and the page;
// the other pages still read; loading the asset fails with the same line.
TEST(LodPagedAsset, FlippedPageByteIsRejected) {
  PagedFile f = writePaged("pagedflip");
  std::string file = f.path.string();
  uint64_t chunkOffset = 0;
  lod::PagedMesh mesh;
  {
    auto reader = asset::AssetReader::open(file);
    ASSERT_TRUE(reader.ok());
    auto meshes = lod::openPagedMeshes(*reader);
    ASSERT_TRUE(meshes.ok());
    mesh = (*meshes)[1];
    chunkOffset = reader->chunks()[mesh.chunk].offset;
  }
  uint32_t page = uint32_t(mesh.table.pages.size() / 2);
  const asset::BlockInfo& b = mesh.blocks.blocks[page];
  test::flipByte(f.path, chunkOffset + b.offset + b.storedBytes / 2);
  auto reader = asset::AssetReader::open(file);
  ASSERT_TRUE(reader.ok()) << "the container's structure is intact: " << reader.error().message;
  auto meshes = lod::openPagedMeshes(*reader);
  ASSERT_TRUE(meshes.ok()) << "the indices are intact: " << meshes.error().message;
  for (uint32_t p = 0; p < mesh.table.pages.size(); ++p) {
    auto read = lod::readPage(*reader, (*meshes)[1], p);
    if (p != page) {
      EXPECT_TRUE(read.ok()) << read.error().message;
      continue;
    }
    ASSERT_FALSE(read.ok());
    const std::string& msg = read.error().message;
    EXPECT_TRUE(mentions(msg, file) && mentions(msg, "CPAG") && mentions(msg, "page " + std::to_string(page))) << msg;
  }
  auto loaded = lod::loadLodAsset(file);
  ASSERT_FALSE(loaded.ok());
  EXPECT_TRUE(mentions(loaded.error().message, "page " + std::to_string(page))) << loaded.error().message;
}

// A damaged index (the page table) fails at open; a truncated file fails before any page is used.
TEST(LodPagedAsset, DamagedIndexAndTruncatedFileAreRejected) {
  PagedFile f = writePaged("pagedtrunc");
  std::string file = f.path.string();
  uint64_t size = std::filesystem::file_size(f.path), indexAt = 0, indexBytes = 0;
  {
    auto reader = asset::AssetReader::open(file);
    ASSERT_TRUE(reader.ok());
    size_t chunk = *reader->find(asset::chunk::ClusterPages);
    indexAt = reader->chunks()[chunk].offset;
    indexBytes = reader->chunks()[chunk].indexBytes;
  }
  auto damaged = f.path.parent_path() / "index.mrg";
  std::filesystem::copy_file(f.path, damaged);
  test::flipByte(damaged, indexAt + indexBytes - 3); // inside the page table
  auto reader = asset::AssetReader::open(damaged.string());
  ASSERT_TRUE(reader.ok());
  auto meshes = lod::openPagedMeshes(*reader);
  ASSERT_FALSE(meshes.ok());
  EXPECT_TRUE(mentions(meshes.error().message, damaged.string()) && mentions(meshes.error().message, "CPAG"))
      << meshes.error().message;

  for (uint64_t keep : {size - 1, size / 2, indexAt + indexBytes / 2}) {
    std::filesystem::resize_file(f.path, keep);
    auto loaded = lod::loadLodAsset(file);
    ASSERT_FALSE(loaded.ok()) << keep;
    EXPECT_TRUE(mentions(loaded.error().message, file)) << loaded.error().message;
  }
}

// The dragon at the default page size: the paged file loads to the CDAG decoder's DAG.
TEST(LodPagedAsset, RealDataDragon) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto baked = lod::bakeLodAsset(*scene, {});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  auto file = test::tempDir("pageddragon") / "dragon.mrg";
  lod::LodWriteOptions options;
  options.paged = true;
  ASSERT_TRUE(lod::saveLodAsset(file.string(), *baked, options).ok());
  auto loaded = lod::loadLodAsset(file.string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  auto reference = lod::decodeDag(lod::encodeDag(baked->dags[0]), "reference");
  ASSERT_TRUE(reference.ok());
  EXPECT_EQ(lod::dagDifference(loaded->dags[0], *reference), "");
  EXPECT_EQ(loaded->dags[0].positions.size(), reference->positions.size());
}
