// The paged cluster DAG: layout invariants (whole groups, coarse to fine, dependencies), the
// residency-aware cut (watertight and overlap-free for every closed resident set, LOCALCUT when all
// is resident, converging to it under its own requests), and the page and page-table codecs
// (exact round trips against the CDAG decoder, corrupt bytes rejected).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "lod_meshes.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/paging.h"
#include "mirage/lod/verify.h"
#include "mirage/shaderio/lod_error.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::lod;

namespace {

std::string message(const Status& s) { return s.ok() ? std::string() : s.error().message; }

// Page units: a root cluster in a root page, a group elsewhere.
uint32_t unitsOf(const PageTable& t, uint32_t p) {
  return p < t.rootPageCount ? t.pages[p].clusterCount : t.pages[p].groupCount;
}

uint32_t minLevel(const PageTable& t, uint32_t p) {
  uint32_t l = ~0u;
  for (uint32_t g : t.groupsOf(p)) l = std::min(l, t.groupLevel[g]);
  return l;
}
uint32_t maxLevel(const PageTable& t, uint32_t p) {
  uint32_t l = 0;
  for (uint32_t g : t.groupsOf(p)) l = std::max(l, t.groupLevel[g]);
  return l;
}

// The DAG as the CDAG decoder gives it (LOD bounds widened by the grid's slack, as the pages'):
// its cuts are what the residency-aware cut reaches with everything resident. The structure is
// the built DAG's, so cuts are verified against the built DAG and the input mesh.
ClusterDag decodedDag(const ClusterDag& dag) {
  Result<ClusterDag> r = decodeDag(encodeDag(dag), "ref.mrg");
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : ClusterDag{};
}

// Layout invariants: every group's member clusters in its page, every cluster in one page, roots
// in the root pages, pages within the budget unless they hold one unit, coarse to fine, and the
// dependencies exactly the other pages holding the parents of the page's groups.
void expectLayout(const ClusterDag& dag, const PagedDag& paged, uint32_t budget, const std::string& what) {
  const PageTable& t = paged.table;
  ASSERT_EQ(t.pages.size(), paged.pages.size()) << what;
  ASSERT_GE(t.rootPageCount, 1u) << what;
  ASSERT_EQ(t.groupPage.size(), dag.groups.size()) << what;
  ASSERT_EQ(t.clusterPage.size(), dag.clusters.size()) << what;
  std::vector<uint32_t> seen(dag.clusters.size(), 0);
  for (uint32_t p = 0; p < t.pages.size(); ++p)
    for (uint32_t c : t.clustersOf(p)) ++seen[c];
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    ASSERT_EQ(seen[c], 1u) << what << ": cluster " << c;
    uint32_t g = dag.clusters[c].group;
    if (g == kNone) {
      EXPECT_LT(t.clusterPage[c], t.rootPageCount) << what << ": root " << c;
    } else {
      EXPECT_EQ(t.clusterPage[c], t.groupPage[g]) << what << ": cluster " << c << " apart from its group";
      EXPECT_GE(t.groupPage[g], t.rootPageCount) << what;
    }
  }
  for (uint32_t p = t.rootPageCount; p < t.pages.size(); ++p) { // members group after group
    std::vector<uint32_t> members;
    for (uint32_t g : t.groupsOf(p)) {
      const Group& gr = dag.groups[g];
      EXPECT_EQ(t.groupClusterCount[g], gr.childCount) << what;
      members.insert(members.end(), dag.groupChildren.begin() + gr.childOffset,
                     dag.groupChildren.begin() + gr.childOffset + gr.childCount);
    }
    std::span<const uint32_t> listed = t.clustersOf(p);
    EXPECT_TRUE(std::equal(members.begin(), members.end(), listed.begin(), listed.end())) << what << ": page " << p;
  }
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    EXPECT_EQ(paged.pages[p].size(), t.pages[p].bytes) << what;
    if (unitsOf(t, p) > 1) {
      EXPECT_LE(t.pages[p].bytes, budget) << what << ": page " << p;
    }
    if (p >= t.rootPageCount + 1) {
      EXPECT_LE(maxLevel(t, p), minLevel(t, p - 1)) << what << ": page " << p << " is coarser than page " << p - 1;
    }
    std::vector<uint32_t> deps;
    for (uint32_t g : t.groupsOf(p)) {
      const Group& gr = dag.groups[g];
      for (uint32_t i = 0; i < gr.parentCount; ++i)
        deps.push_back(t.clusterPage[dag.groupParents[gr.parentOffset + i]]);
    }
    std::sort(deps.begin(), deps.end());
    deps.erase(std::unique(deps.begin(), deps.end()), deps.end());
    deps.erase(std::remove(deps.begin(), deps.end(), p), deps.end());
    std::span<const uint32_t> stored = t.dependenciesOf(p);
    EXPECT_TRUE(std::equal(deps.begin(), deps.end(), stored.begin(), stored.end())) << what << ": page " << p;
    for (uint32_t d : stored) EXPECT_LT(d, p) << what << ": page order is not a load order";
  }
}

// A random resident set closed under the dependencies: random pages and everything they need.
std::vector<uint8_t> randomResidency(const PageTable& t, std::mt19937& rng, float share) {
  std::vector<uint8_t> r(t.pages.size(), 0);
  std::bernoulli_distribution pick(share);
  for (uint32_t p = 0; p < t.pages.size(); ++p) r[p] = p < t.rootPageCount || pick(rng);
  for (uint32_t p = uint32_t(t.pages.size()); p-- > 0;) // dependencies have lower indices
    if (r[p])
      for (uint32_t d : t.dependenciesOf(p)) r[d] = 1;
  return r;
}

float meshRadius(const ClusterDag& dag, glm::vec3& centre) {
  Bounds box;
  for (glm::vec3 p : dag.positions) box.add(p);
  centre = box.center();
  return 0.5f * glm::length(box.extent());
}

// Views: object-space thresholds around the group errors, and cameras at 0.3 to 30 mesh radii
// (1080 pixels high, 45 degrees) with tau 0.25 to 8 pixels.
std::vector<CutView> randomViews(const ClusterDag& dag, std::mt19937& rng, size_t count) {
  glm::vec3 centre;
  float radius = meshRadius(dag, centre);
  float maxError = 0.0f;
  for (const Group& g : dag.groups) maxError = std::max(maxError, g.bounds.error);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<CutView> views;
  for (size_t i = 0; i < count; ++i) {
    CutView v;
    if (i % 3 == 0) {
      v.tau = i == 0 ? 0.0f : maxError * std::exp2(-10.0f * u(rng)) * 1.2f;
    } else {
      glm::vec3 dir = glm::normalize(glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f) + glm::vec3(1e-3f));
      v.eye = centre + dir * radius * std::exp2(std::log2(0.3f) + u(rng) * std::log2(100.0f));
      v.znear = 1e-3f * radius;
      v.pixelScale = shaderio::projectionScale(1.0f / std::tan(glm::radians(22.5f)), 1080.0f);
      v.tau = std::exp2(-2.0f + 5.0f * u(rng));
    }
    views.push_back(v);
  }
  return views;
}

// Random closed resident sets under random views: the cut is watertight and overlap-free, draws
// only resident clusters, is LOCALCUT with everything resident and the roots with only the root
// pages.
void expectResidentCuts(const ClusterDag& dag, const PageTable& t, const Mesh& mesh, size_t views, uint32_t seed,
                        const std::string& what) {
  ClusterDag decoded = decodedDag(dag);
  std::mt19937 rng(seed);
  std::vector<uint8_t> all(t.pages.size(), 1), rootsOnly(t.pages.size(), 0);
  std::fill(rootsOnly.begin(), rootsOnly.begin() + t.rootPageCount, 1);
  std::vector<uint32_t> roots = dag.roots;
  std::sort(roots.begin(), roots.end());
  uint32_t partial = 0; // cuts that are neither the full cut nor the roots
  for (const CutView& v : randomViews(dag, rng, views)) {
    std::string view = what + " tau " + std::to_string(v.tau) + (v.pixelScale > 0 ? " px" : " object");
    ResidentCut full = selectResidentCut(dag, t, all, v);
    EXPECT_EQ(full.clusters, selectCut(decoded, v)) << view;
    if (v.pixelScale == 0.0f) {
      EXPECT_EQ(full.clusters, selectCut(decoded, v.tau)) << view;
    }
    EXPECT_TRUE(full.requests.empty()) << view;
    EXPECT_TRUE(wantedPages(t, all, v).empty()) << view;
    EXPECT_EQ(selectResidentCut(dag, t, rootsOnly, v).clusters, roots) << view;
    for (float share : {0.05f, 0.3f, 0.7f}) {
      std::vector<uint8_t> resident = randomResidency(t, rng, share);
      ASSERT_TRUE(residencyClosed(t, resident));
      ResidentCut cut = selectResidentCut(dag, t, resident, v);
      partial += cut.clusters != full.clusters && cut.clusters != roots;
      for (uint32_t c : cut.clusters) ASSERT_TRUE(resident[t.clusterPage[c]]) << view;
      Status s = verifyCut(dag, cut.clusters, mesh);
      ASSERT_TRUE(s.ok()) << view << " share " << share << ": " << message(s);
      for (const PageRequest& r : cut.requests) {
        EXPECT_FALSE(resident[r.page]) << view;
        EXPECT_GT(r.priority, 1.0f) << view;
      }
    }
  }
  EXPECT_GT(partial, 0u) << what;
}

// Streaming under one view: start from the root pages, load what the cut asks for (with its
// missing dependencies) each round; every cut on the way is watertight, the rounds end within the
// DAG's levels, and the last cut is LOCALCUT with exactly the wanted pages resident.
void expectStreamingConverges(const ClusterDag& dag, const PageTable& t, const Mesh& mesh, const CutView& v,
                              const std::string& what) {
  std::vector<uint8_t> resident(t.pages.size(), 0);
  std::fill(resident.begin(), resident.begin() + t.rootPageCount, 1);
  std::vector<PageRequest> wanted = wantedPages(t, resident, v);
  std::vector<uint8_t> listed(t.pages.size(), 0);
  for (const PageRequest& r : wanted) { // in order, each page's dependencies come first
    for (uint32_t d : t.dependenciesOf(r.page)) EXPECT_TRUE(resident[d] || listed[d]) << what;
    listed[r.page] = 1;
  }
  uint32_t rounds = 0;
  for (;; ++rounds) {
    ResidentCut cut = selectResidentCut(dag, t, resident, v);
    Status s = verifyCut(dag, cut.clusters, mesh);
    ASSERT_TRUE(s.ok()) << what << " round " << rounds << ": " << message(s);
    if (cut.requests.empty()) {
      EXPECT_EQ(cut.clusters, selectCut(decodedDag(dag), v)) << what;
      break;
    }
    ASSERT_LT(rounds, dag.levelCount()) << what; // one round per group level at most
    for (const PageRequest& r : cut.requests) {
      EXPECT_TRUE(listed[r.page]) << what << ": requested page " << r.page << " is not wanted";
      resident[r.page] = 1;
    }
    for (uint32_t p = uint32_t(t.pages.size()); p-- > 0;)
      if (resident[p])
        for (uint32_t d : t.dependenciesOf(p)) resident[d] = 1;
  }
  EXPECT_TRUE(wantedPages(t, resident, v).empty()) << what;
  for (uint32_t p = t.rootPageCount; p < t.pages.size(); ++p)
    EXPECT_EQ(bool(resident[p]), bool(listed[p])) << what << ": page " << p;
}

// Every page decodes against the table to exactly the clusters of the CDAG decoder's DAG (same
// grid): counts, links, LOD bounds, indices and vertex attributes bit for bit; positions within
// the grid step of the built DAG's.
void expectPagesDecode(const ClusterDag& dag, const PagedDag& paged, const std::string& what) {
  std::optional<ClusterDag> ref = decodedDag(dag);
  const PageTable& t = paged.table;
  Result<PageTable> table = decodePageTable(encodePageTable(t), "table.mrg");
  ASSERT_TRUE(table.ok()) << what << ": " << table.error().message;
  EXPECT_EQ(table->pageGroups, t.pageGroups);
  EXPECT_EQ(table->pageClusters, t.pageClusters);
  EXPECT_EQ(table->dependencies, t.dependencies);
  EXPECT_EQ(table->groupPage, t.groupPage);
  EXPECT_EQ(table->clusterPage, t.clusterPage);
  EXPECT_EQ(table->groupLevel, t.groupLevel);
  EXPECT_EQ(table->groupClusterCount, t.groupClusterCount);
  EXPECT_EQ(table->rootPageCount, t.rootPageCount);
  ASSERT_EQ(table->groupBounds.size(), ref->groups.size());
  for (size_t g = 0; g < ref->groups.size(); ++g)
    ASSERT_EQ(std::memcmp(&table->groupBounds[g], &ref->groups[g].bounds, sizeof(LodBounds)), 0)
        << what << " group " << g;
  Bounds box;
  for (glm::vec3 p : dag.positions) box.add(p);
  float step = std::max({box.extent().x, box.extent().y, box.extent().z}) / 65535.0f;
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    Result<PageData> page = decodePage(paged.pages[p], *table, p, "scene.mrg");
    ASSERT_TRUE(page.ok()) << what << ": " << page.error().message;
    ASSERT_EQ(page->clusters.size(), t.pages[p].clusterCount);
    EXPECT_EQ(page->positions.size(), t.pages[p].vertexCount);
    for (size_t i = 0; i < page->clusters.size(); ++i) {
      const Cluster& a = page->clusters[i];
      const Cluster& b = ref->clusters[page->clusterIds[i]];
      std::string name = what + " page " + std::to_string(p) + " cluster " + std::to_string(page->clusterIds[i]);
      ASSERT_EQ(a.vertexCount, b.vertexCount) << name;
      ASSERT_EQ(a.triangleCount, b.triangleCount) << name;
      EXPECT_EQ(a.level, b.level) << name;
      EXPECT_EQ(a.group, b.group) << name;
      EXPECT_EQ(a.generatingGroup, b.generatingGroup) << name;
      EXPECT_EQ(std::memcmp(&a.self, &b.self, sizeof(LodBounds)), 0) << name;
      EXPECT_EQ(std::memcmp(&a.parent, &b.parent, sizeof(LodBounds)), 0) << name;
      EXPECT_EQ(std::memcmp(&a.bounds, &b.bounds, sizeof(LodBounds)), 0) << name;
      ASSERT_TRUE(std::equal(page->clusterIndices.begin() + a.triangleOffset * 3,
                             page->clusterIndices.begin() + (a.triangleOffset + a.triangleCount) * 3,
                             ref->clusterIndices.begin() + b.triangleOffset * 3))
          << name;
      for (uint32_t k = 0; k < a.vertexCount; ++k) {
        uint32_t pv = page->clusterVertices[a.vertexOffset + k];
        uint32_t rv = ref->clusterVertices[b.vertexOffset + k];
        glm::vec3 pos = page->positions[pv];
        ASSERT_EQ(std::memcmp(&pos, &ref->positions[ref->vertexPosition[rv]], sizeof(glm::vec3)), 0) << name;
        glm::vec3 d = glm::abs(pos - dag.positions[dag.vertexPosition[rv]]);
        ASSERT_LE(std::max({d.x, d.y, d.z}), step * 0.52f) << name;
        if (!ref->normals.empty()) {
          ASSERT_EQ(page->normals[pv], ref->normals[rv]) << name;
        }
        if (!ref->uv0.empty()) {
          ASSERT_EQ(page->uv0[pv], ref->uv0[rv]) << name;
        }
      }
    }
  }
}

ClusterDag build(const Mesh& mesh) {
  Result<ClusterDag> dag = buildClusterDag(mesh);
  EXPECT_TRUE(dag.ok()) << (dag.ok() ? "" : dag.error().message);
  return dag.ok() ? std::move(dag).value() : ClusterDag{};
}

} // namespace

// Generated meshes (closed, open, UV seams, tunnels) at a small page size, so each has many pages
// across several levels, and at the default size.
TEST(LodPaging, GeneratedMeshesPageAndCutCleanly) {
  uint32_t seed = 1;
  for (const Mesh& mesh : {lodtest::makeBlob(5, 1), lodtest::makeTerrain(80, 2), lodtest::makeSeamBlob(5, 3),
                           lodtest::makeDrilledSlab()}) {
    ClusterDag dag = build(mesh);
    ASSERT_FALSE(dag.clusters.empty());
    for (uint32_t budget : {6u * 1024u, 48u * 1024u, PageConfig{}.pageBytes}) {
      PageConfig cfg;
      cfg.pageBytes = budget;
      PagedDag paged = buildPages(dag, cfg);
      std::string what = mesh.name + " at " + std::to_string(budget) + " B";
      expectLayout(dag, paged, budget, what);
      if (budget < PageConfig{}.pageBytes) {
        if (budget < 8192) {
          EXPECT_GT(paged.table.pages.size(), 8u) << what;
        }
        expectResidentCuts(dag, paged.table, mesh, 16, ++seed, what);
        std::mt19937 rng(seed);
        for (const CutView& v : randomViews(dag, rng, 6)) expectStreamingConverges(dag, paged.table, mesh, v, what);
      }
      expectPagesDecode(dag, paged, what);
    }
  }
}

// Roots over several root pages (a DAG stopped at 8 roots, a 1 KiB budget), all always resident.
TEST(LodPaging, RootsSpanSeveralRootPages) {
  Mesh mesh = lodtest::makeTerrain(60, 4);
  BuildConfig bc;
  bc.rootClusters = 8;
  Result<ClusterDag> dag = buildClusterDag(mesh, bc);
  ASSERT_TRUE(dag.ok());
  ASSERT_GT(dag->roots.size(), 2u);
  PageConfig cfg;
  cfg.pageBytes = 1024;
  PagedDag paged = buildPages(*dag, cfg);
  EXPECT_GT(paged.table.rootPageCount, 1u);
  expectLayout(*dag, paged, cfg.pageBytes, "terrain, 8 roots");
  expectResidentCuts(*dag, paged.table, mesh, 9, 5, "terrain, 8 roots");
  expectPagesDecode(*dag, paged, "terrain, 8 roots");
}

TEST(LodPaging, CorruptPagesAndTablesAreRejected) {
  ClusterDag dag = build(lodtest::makeSeamBlob(3, 9));
  PageConfig cfg;
  cfg.pageBytes = 8 * 1024;
  PagedDag paged = buildPages(dag, cfg);
  const PageTable& t = paged.table;
  ASSERT_GT(t.pages.size(), 3u);
  uint32_t p = t.rootPageCount + 1;
  const std::vector<uint8_t>& bytes = paged.pages[p];
  for (size_t n = 0; n < bytes.size(); n += std::max<size_t>(1, bytes.size() / 300)) {
    auto r = decodePage(std::span(bytes.data(), n), t, p, "cut.mrg");
    ASSERT_FALSE(r.ok()) << "truncated to " << n;
    EXPECT_NE(r.error().message.find("cut.mrg: page " + std::to_string(p)), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
  std::mt19937 rng(5);
  for (int i = 0; i < 3000; ++i) {
    std::vector<uint8_t> bad = bytes;
    int flips = 1 + int(rng() % 4);
    for (int f = 0; f < flips; ++f) bad[rng() % bad.size()] ^= uint8_t(1u << (rng() % 8));
    auto r = decodePage(bad, t, p, "flip.mrg"); // must return, either way; a decoded page stays in range
    if (!r.ok()) continue;
    for (const Cluster& c : r->clusters) {
      ASSERT_LE(size_t(c.vertexOffset) + c.vertexCount, r->clusterVertices.size());
      for (uint32_t k = 0; k < c.triangleCount * 3u; ++k)
        ASSERT_LT(r->clusterIndices[size_t(c.triangleOffset) * 3 + k], c.vertexCount);
    }
    for (uint32_t v : r->clusterVertices) ASSERT_LT(v, r->positions.size());
  }
  // Another page's bytes, a page number past the table, another version.
  auto swapped = decodePage(paged.pages[p + 1], t, p, "swap.mrg");
  ASSERT_FALSE(swapped.ok());
  EXPECT_NE(swapped.error().message.find("swap.mrg: page " + std::to_string(p) + ": holds page"), std::string::npos)
      << swapped.error().message;
  EXPECT_FALSE(decodePage(bytes, t, uint32_t(t.pages.size()), "x.mrg").ok());
  std::vector<uint8_t> version = bytes;
  version[0] = 99;
  auto v = decodePage(version, t, p, "v.mrg");
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().message.find("version 99"), std::string::npos);

  std::vector<uint8_t> table = encodePageTable(t);
  for (size_t n = 0; n < table.size(); n += std::max<size_t>(1, table.size() / 300))
    EXPECT_FALSE(decodePageTable(std::span(table.data(), n), "t.mrg").ok()) << "truncated to " << n;
  for (int i = 0; i < 3000; ++i) {
    std::vector<uint8_t> bad = table;
    bad[rng() % bad.size()] ^= uint8_t(1u << (rng() % 8));
    auto r = decodePageTable(bad, "flip.mrg");
    if (!r.ok()) {
      EXPECT_NE(r.error().message.find("flip.mrg: page table"), std::string::npos) << r.error().message;
      continue;
    }
    // A table that decodes is consistent: every page's lists in range, dependencies below it.
    for (uint32_t q = 0; q < r->pages.size(); ++q) {
      for (uint32_t d : r->dependenciesOf(q)) ASSERT_LT(d, q);
      for (uint32_t c : r->clustersOf(q)) ASSERT_EQ(r->clusterPage[c], q);
    }
  }
}

namespace {

std::optional<Mesh> realMesh(const std::filesystem::path& path) { return lodtest::readAsciiPly(path); }

// Real scans: layout, a few residency cuts and streaming runs, every page decoded, and the page
// size distribution at the default size printed (docs/lod.md, "Paging").
void realData(const Mesh& mesh, size_t views) {
  ClusterDag dag = build(mesh);
  ASSERT_FALSE(dag.clusters.empty());
  PageConfig cfg;
  PagedDag paged = buildPages(dag, cfg);
  const PageTable& t = paged.table;
  expectLayout(dag, paged, cfg.pageBytes, mesh.name);
  expectPagesDecode(dag, paged, mesh.name);
  expectResidentCuts(dag, t, mesh, views, 3, mesh.name);
  std::mt19937 rng(9);
  for (const CutView& v : randomViews(dag, rng, 2)) expectStreamingConverges(dag, t, mesh, v, mesh.name);

  // Spatial coherence: the groups sharing a level-0 page lie close together (Morton order): the
  // largest distance between their centres is under half of what pages of random level-0 groups
  // of the same sizes give, where the level has enough groups for the comparison to mean much.
  auto spreadOf = [&](std::span<const uint32_t> ids) {
    float far = 0.0f;
    for (uint32_t a : ids)
      for (uint32_t b : ids) far = std::max(far, glm::distance(t.groupBounds[a].center, t.groupBounds[b].center));
    return far;
  };
  std::vector<uint32_t> level0;
  for (uint32_t g = 0; g < t.groupLevel.size(); ++g)
    if (t.groupLevel[g] == 0) level0.push_back(g);
  std::shuffle(level0.begin(), level0.end(), rng);
  float spread = 0.0f, randomSpread = 0.0f;
  size_t taken = 0;
  for (uint32_t p = t.rootPageCount; p < t.pages.size(); ++p) {
    if (maxLevel(t, p) != 0 || t.pages[p].groupCount < 2) continue;
    spread += spreadOf(t.groupsOf(p));
    randomSpread += spreadOf(std::span(level0).subspan(taken % (level0.size() - 8), t.pages[p].groupCount));
    taken += t.pages[p].groupCount;
  }
  if (level0.size() >= 64) { // the bunny has 17
    EXPECT_LT(spread, 0.5f * randomSpread) << mesh.name;
  }

  std::vector<uint32_t> sizes, groups;
  uint64_t total = 0;
  uint32_t single = 0, oversized = 0;
  for (uint32_t p = t.rootPageCount; p < t.pages.size(); ++p) {
    sizes.push_back(t.pages[p].bytes);
    groups.push_back(t.pages[p].groupCount);
    single += t.pages[p].groupCount == 1;
    oversized += t.pages[p].bytes > cfg.pageBytes;
  }
  for (const PageInfo& p : t.pages) total += p.bytes;
  std::sort(sizes.begin(), sizes.end());
  std::sort(groups.begin(), groups.end());
  auto at = [](const std::vector<uint32_t>& v, double q) {
    return v[std::min(v.size() - 1, size_t(q * double(v.size())))];
  };
  std::printf("%s: %zu triangles, %zu clusters, %zu groups, %u levels; CDAG %zu B\n", mesh.name.c_str(),
              size_t(dag.inputTriangles), dag.clusters.size(), dag.groups.size(), dag.levelCount(),
              encodeDag(dag).size());
  std::printf("  level-0 pages: largest distance between their groups' centres %.2f of random pages'\n",
              spread / randomSpread);
  std::printf("  %zu pages (%u root, %u B), %llu B in all, table %zu B; group pages' bytes min %u p10 %u median %u "
              "p90 %u max %u, mean fill %.1f %%; groups per page min %u median %u max %u; one group: %u, over "
              "budget: %u\n",
              t.pages.size(), t.rootPageCount, t.pages[0].bytes, (unsigned long long)total, encodePageTable(t).size(),
              sizes.front(), at(sizes, 0.1), at(sizes, 0.5), at(sizes, 0.9), sizes.back(),
              100.0 * double(total - t.pages[0].bytes) / double(sizes.size()) / double(cfg.pageBytes), groups.front(),
              at(groups, 0.5), groups.back(), single, oversized);
}

} // namespace

TEST(LodPaging, RealDataBunny) {
  MIRAGE_REQUIRE_DATA(path, "stanford-bunny/bun_zipper.ply");
  std::optional<Mesh> mesh = realMesh(path);
  ASSERT_TRUE(mesh.has_value());
  realData(*mesh, 12);
}

TEST(LodPaging, RealDataDragon) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply");
  std::optional<Mesh> mesh = realMesh(path);
  ASSERT_TRUE(mesh.has_value());
  realData(*mesh, 4);
}
