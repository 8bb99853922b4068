// A paged DAG's page table and one page (lod/paging.h): u32 table size, the table bytes, u32 page
// number, then the page bytes. What the decoders accept is used without further checks by the
// residency code and the GPU upload, so every id and range must hold; the harness checks that,
// runs the table-only request rule, and re-encodes the table (it must decode to the same table).
#include <cstring>

#include "fuzz_support.h"
#include "mirage/lod/paging.h"

using namespace mirage;

namespace {

void checkTable(const lod::PageTable& t) {
  fuzz::check(t.rootPageCount >= 1 && t.rootPageCount <= t.pages.size(), "root page count out of range");
  fuzz::check(t.groupPage.size() == t.groupLevel.size() && t.groupBounds.size() == t.groupLevel.size(),
              "per-group arrays differ in size");
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    const lod::PageInfo& info = t.pages[p];
    fuzz::check(size_t(info.groupOffset) + info.groupCount <= t.pageGroups.size() &&
                    size_t(info.clusterOffset) + info.clusterCount <= t.pageClusters.size() &&
                    size_t(info.dependencyOffset) + info.dependencyCount <= t.dependencies.size(),
                "page range out of bounds");
    for (uint32_t g : t.groupsOf(p)) fuzz::check(g < t.groupPage.size() && t.groupPage[g] == p, "group page");
    for (uint32_t c : t.clustersOf(p)) fuzz::check(c < t.clusterPage.size() && t.clusterPage[c] == p, "cluster page");
    for (uint32_t d : t.dependenciesOf(p)) fuzz::check(d < p, "dependency not below its page");
  }
}

void checkPage(const lod::PageData& page) {
  for (const lod::Cluster& c : page.clusters) {
    fuzz::check(size_t(c.vertexOffset) + c.vertexCount <= page.clusterVertices.size() &&
                    (size_t(c.triangleOffset) + c.triangleCount) * 3 <= page.clusterIndices.size(),
                "cluster range out of bounds");
    for (uint32_t k = 0; k < c.triangleCount * 3u; ++k)
      fuzz::check(page.clusterIndices[size_t(c.triangleOffset) * 3 + k] < c.vertexCount, "local index out of range");
  }
  for (uint32_t v : page.clusterVertices) fuzz::check(v < page.positions.size(), "vertex out of range");
  fuzz::check(page.normals.empty() || page.normals.size() == page.positions.size(), "normal count");
  fuzz::check(page.uv0.empty() || page.uv0.size() == page.positions.size(), "uv count");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  uint32_t tableSize = 0, page = 0;
  if (size < 4) return 0;
  std::memcpy(&tableSize, data, 4);
  if (tableSize > size - 4 || size - 4 - tableSize < 4) return 0;
  std::span<const uint8_t> tableBytes(data + 4, tableSize);
  std::memcpy(&page, data + 4 + tableSize, 4);
  std::span<const uint8_t> pageBytes(data + 8 + tableSize, size - 8 - tableSize);

  Result<lod::PageTable> table = lod::decodePageTable(tableBytes, "in.mrg");
  if (!table) {
    fuzz::checkOneLine(table.error());
    return 0;
  }
  checkTable(*table);
  std::vector<uint8_t> resident(table->pages.size(), 0);
  for (uint32_t p = 0; p < table->rootPageCount; ++p) resident[p] = 1;
  fuzz::check(lod::residencyClosed(*table, resident), "the root pages alone are not closed");
  for (float tau : {0.0f, 1e-3f, 1.0f}) (void)lod::wantedPages(*table, resident, lod::CutView{.tau = tau});

  std::vector<uint8_t> again = lod::encodePageTable(*table);
  Result<lod::PageTable> back = lod::decodePageTable(again, "again.mrg");
  if (!back) fuzz::fail("a decoded page table re-encodes to bytes decodePageTable rejects: " + back.error().message);
  fuzz::check(back->pageClusters == table->pageClusters && back->dependencies == table->dependencies,
              "page table round trip changed it");

  Result<lod::PageData> decoded = lod::decodePage(pageBytes, *table, page, "in.mrg");
  if (!decoded) {
    fuzz::checkOneLine(decoded.error());
    return 0;
  }
  checkPage(*decoded);
  return 0;
}
