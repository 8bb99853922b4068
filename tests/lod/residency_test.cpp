// The residency manager (lod/residency.h): the budget is never exceeded and the resident set stays
// closed after every step, eviction follows use and priority, and streaming rounds driven by the
// CPU reference of the GPU feedback reach the full cut when the budget holds it (and a crack-free
// coarser cut when it does not).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lod_meshes.h"
#include "mirage/lod/paging.h"
#include "mirage/lod/residency.h"
#include "mirage/lod/verify.h"
#include "mirage/shaderio/lod_error.h"

using namespace mirage;
using namespace mirage::lod;

namespace {

struct Paged {
  Mesh mesh;
  ClusterDag dag;
  PagedDag paged;
};

Paged makePaged(uint32_t blobLevel, uint32_t pageBytes) {
  Paged p;
  p.mesh = lodtest::makeBlob(blobLevel, 1);
  Result<ClusterDag> dag = buildClusterDag(p.mesh);
  EXPECT_TRUE(dag.ok());
  if (dag.ok()) p.dag = std::move(dag).value();
  PageConfig cfg;
  cfg.pageBytes = pageBytes;
  p.paged = buildPages(p.dag, cfg);
  return p;
}

ResidencyGraph graphOf(const PageTable& t) {
  const PageTable* tables[] = {&t};
  return residencyGraph(std::span<const PageTable* const>(tables),
                        [&](uint32_t, uint32_t p) { return uint64_t(t.pages[p].bytes); });
}

// A camera at `distance` mesh radii, 1080 pixels high, tau 1 pixel.
CutView cameraView(const ClusterDag& dag, float distance, glm::vec3 dir = {0.3f, 0.4f, 1.0f}) {
  Bounds box;
  for (glm::vec3 p : dag.positions) box.add(p);
  CutView v;
  float radius = 0.5f * glm::length(box.extent());
  v.eye = box.center() + glm::normalize(dir) * radius * distance;
  v.znear = 1e-3f * radius;
  v.pixelScale = shaderio::projectionScale(1.0f / std::tan(glm::radians(22.5f)), 1080.0f);
  v.tau = 1.0f;
  return v;
}

uint64_t bytesOf(const PageTable& t, const std::vector<PageRequest>& pages) {
  uint64_t b = 0;
  for (const PageRequest& r : pages) b += t.pages[r.page].bytes;
  return b;
}

uint64_t rootBytes(const PageTable& t) {
  uint64_t b = 0;
  for (uint32_t p = 0; p < t.rootPageCount; ++p) b += t.pages[p].bytes;
  return b;
}

// Streams under `view` until a step changes nothing; checks budget and closure after every step and
// that every cut on the way is watertight. Returns the steps taken.
// With `prefetch`, the view's prefetchFeedback is merged into every step's feedback.
uint32_t stream(const Paged& p, ResidencyManager& m, const CutView& view, uint32_t maxSteps = 200,
                bool prefetch = false) {
  const PageTable& t = p.paged.table;
  for (uint32_t step = 0; step < maxSteps; ++step) {
    std::vector<uint8_t> resident(m.resident().begin(), m.resident().end());
    ResidentCut cut = selectResidentCut(p.dag, t, resident, view);
    Status s = verifyCut(p.dag, cut.clusters, p.mesh);
    EXPECT_TRUE(s.ok()) << "step " << step << ": " << (s.ok() ? "" : s.error().message);
    std::vector<float> feedback = residencyFeedback(p.dag, t, resident, view);
    if (prefetch) mergeFeedback(feedback, prefetchFeedback(t, view));
    ResidencyStep st = m.step(feedback);
    EXPECT_TRUE(m.consistent()) << "step " << step;
    EXPECT_LE(m.residentBytes(), m.config().budgetBytes);
    EXPECT_TRUE(residencyClosed(t, m.resident()));
    EXPECT_LE(st.loaded.size(), m.config().maxLoadsPerStep);
    if (st.loaded.empty() && st.evicted.empty()) return step;
  }
  ADD_FAILURE() << "no convergence in " << maxSteps << " steps";
  return maxSteps;
}

} // namespace

TEST(LodResidency, RootPagesAboveTheBudgetAreRefused) {
  Paged p = makePaged(4, 4096);
  const PageTable& t = p.paged.table;
  auto m = ResidencyManager::create(graphOf(t), {rootBytes(t) - 1, 8});
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("root pages"), std::string::npos) << m.error().message;
  auto ok = ResidencyManager::create(graphOf(t), {rootBytes(t), 8});
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(ok->residentBytes(), rootBytes(t));
  EXPECT_TRUE(ok->consistent());
}

// With room for every page the view wants, the rounds end with exactly those pages resident and
// the cut is LOCALCUT; a tighter budget holding them still converges to it.
TEST(LodResidency, StreamingReachesTheFullCutWhenTheBudgetAllows) {
  Paged p = makePaged(5, 4096);
  const PageTable& t = p.paged.table;
  ASSERT_GT(t.pages.size(), 12u);
  for (float distance : {1.5f, 4.0f}) {
    CutView v = cameraView(p.dag, distance);
    std::vector<uint8_t> roots(t.pages.size(), 0);
    std::fill(roots.begin(), roots.begin() + t.rootPageCount, 1);
    std::vector<PageRequest> wanted = wantedPages(t, roots, v);
    ASSERT_FALSE(wanted.empty());
    uint64_t need = rootBytes(t) + bytesOf(t, wanted);
    for (uint64_t budget : {uint64_t(1) << 40, need}) {
      auto m = ResidencyManager::create(graphOf(t), {budget, 4});
      ASSERT_TRUE(m.ok());
      stream(p, *m, v);
      std::vector<uint8_t> resident(m->resident().begin(), m->resident().end());
      EXPECT_TRUE(wantedPages(t, resident, v).empty()) << "distance " << distance << " budget " << budget;
      ResidentCut cut = selectResidentCut(p.dag, t, resident, v);
      EXPECT_TRUE(cut.requests.empty());
      std::vector<uint8_t> all(t.pages.size(), 1);
      EXPECT_EQ(cut.clusters, selectResidentCut(p.dag, t, all, v).clusters);
      EXPECT_EQ(m->residentBytes(), need) << "only the wanted pages are loaded";
    }
  }
}

// Budgets below the view's needs: never exceeded, the resident set closed, every cut watertight,
// and the rounds still end (no page thrashes).
TEST(LodResidency, TightBudgetsStayWithinAndConverge) {
  Paged p = makePaged(5, 4096);
  const PageTable& t = p.paged.table;
  CutView v = cameraView(p.dag, 1.2f);
  std::vector<uint8_t> roots(t.pages.size(), 0);
  std::fill(roots.begin(), roots.begin() + t.rootPageCount, 1);
  uint64_t need = rootBytes(t) + bytesOf(t, wantedPages(t, roots, v));
  for (double share : {0.2, 0.5, 0.8}) {
    uint64_t budget = rootBytes(t) + uint64_t(double(need - rootBytes(t)) * share);
    auto m = ResidencyManager::create(graphOf(t), {budget, 6});
    ASSERT_TRUE(m.ok());
    stream(p, *m, v);
    EXPECT_GT(m->residentPages(), t.rootPageCount) << share;
    EXPECT_LE(m->residentBytes(), budget);
  }
}

// A moving camera: near one side, then near the other side. The second view's pages evict the first
// view's unused ones (never one another resident page depends on), and the first view comes back
// to its full cut after returning.
TEST(LodResidency, MovingCameraEvictsAndReloads) {
  Paged p = makePaged(5, 4096);
  const PageTable& t = p.paged.table;
  CutView a = cameraView(p.dag, 1.05f, {1, 0.2f, 0.1f}), b = cameraView(p.dag, 1.05f, {-1, -0.2f, -0.1f});
  a.tau = b.tau = 24.0f; // the far side of the mesh needs little
  std::vector<uint8_t> roots(t.pages.size(), 0);
  std::fill(roots.begin(), roots.begin() + t.rootPageCount, 1);
  uint64_t needA = bytesOf(t, wantedPages(t, roots, a)), needB = bytesOf(t, wantedPages(t, roots, b));
  std::vector<PageRequest> both = wantedPages(t, roots, a);
  for (const PageRequest& r : wantedPages(t, roots, b))
    if (std::none_of(both.begin(), both.end(), [&](const PageRequest& q) { return q.page == r.page; }))
      both.push_back(r);
  uint64_t budget = rootBytes(t) + std::max(needA, needB);
  ASSERT_GT(rootBytes(t) + bytesOf(t, both), budget) << "the two views' pages do not fit together";
  auto m = ResidencyManager::create(graphOf(t), {budget, 8});
  ASSERT_TRUE(m.ok());
  stream(p, *m, a);
  std::vector<uint8_t> atA(m->resident().begin(), m->resident().end());
  EXPECT_TRUE(wantedPages(t, atA, a).empty());
  stream(p, *m, b);
  std::vector<uint8_t> atB(m->resident().begin(), m->resident().end());
  EXPECT_TRUE(wantedPages(t, atB, b).empty());
  uint32_t evicted = 0;
  for (uint32_t q = 0; q < t.pages.size(); ++q) evicted += atA[q] && !atB[q];
  EXPECT_GT(evicted, 0u);
  stream(p, *m, a);
  std::vector<uint8_t> back(m->resident().begin(), m->resident().end());
  EXPECT_TRUE(wantedPages(t, back, a).empty());
}

// Eviction order on a hand-made graph: 0 root; 1 and 2 depend on 0; 3 depends on 1. Budget: the
// root and two pages. Unused pages go first (least recently used first), a page with a resident
// dependent never, used pages only for a request of higher priority.
TEST(LodResidency, EvictionOrder) {
  ResidencyGraph g;
  g.pageOffset = {0};
  g.bytes = {10, 10, 10, 10, 10};
  g.root = {1, 0, 0, 0, 0};
  g.dependencyOffset = {0, 0, 1, 2, 3, 4};
  g.dependencies = {0, 0, 1, 0};
  auto made = ResidencyManager::create(g, {30, 8});
  ASSERT_TRUE(made.ok());
  ResidencyManager& m = *made;
  auto feedback = [](std::initializer_list<std::pair<uint32_t, float>> v) {
    std::vector<float> f(5, 0.0f);
    for (auto [p, x] : v) f[p] = x;
    return f;
  };
  ResidencyStep s = m.step(feedback({{3, 5.0f}})); // 3 with its dependency 1 first
  EXPECT_EQ(s.loaded, (std::vector<uint32_t>{1, 3}));
  EXPECT_TRUE(s.evicted.empty());
  // 2 asked at priority 2 while 1 and 3 are used at 5: nothing may go (1 has a dependent).
  s = m.step(feedback({{0, 9.0f}, {1, 5.0f}, {3, 5.0f}, {2, 2.0f}}));
  EXPECT_TRUE(s.loaded.empty());
  EXPECT_EQ(s.unfit, 1u);
  // 3 used at 1.5 only: a request of 2 evicts it (lower priority), never 1 (3 depended on it).
  s = m.step(feedback({{1, 5.0f}, {3, 1.5f}, {2, 2.0f}}));
  EXPECT_EQ(s.evicted, (std::vector<uint32_t>{3}));
  EXPECT_EQ(s.loaded, (std::vector<uint32_t>{2}));
  // 4 asked while nothing is used now: 1 (last used a step before 2) goes first.
  s = m.step(feedback({{2, 1.0f}}));
  s = m.step(feedback({{4, 1.1f}}));
  EXPECT_EQ(s.evicted, (std::vector<uint32_t>{1}));
  EXPECT_EQ(s.loaded, (std::vector<uint32_t>{4}));
  EXPECT_TRUE(m.consistent());
}

// Uploads per step are bounded: a request whose closure does not fit the step waits.
TEST(LodResidency, UploadsPerStepAreBounded) {
  Paged p = makePaged(5, 4096);
  const PageTable& t = p.paged.table;
  CutView v = cameraView(p.dag, 1.2f);
  auto m = ResidencyManager::create(graphOf(t), {uint64_t(1) << 40, 2});
  ASSERT_TRUE(m.ok());
  uint32_t steps = stream(p, *m, v);
  std::vector<uint8_t> roots(t.pages.size(), 0);
  std::fill(roots.begin(), roots.begin() + t.rootPageCount, 1);
  EXPECT_GE(steps, uint32_t(wantedPages(t, roots, v).size() / 2));
}

// A camera cut (a far view, then a near one from the other side): the feedback asks for a level's
// pages only once the level above is resident, one round per level; with the view's prefetch merged
// in, the pages of every level are asked for together, so the cut converges in fewer rounds, within
// the budget and closed after every round (stream checks), to the same full cut. With a budget that
// only just holds the near view, prefetch converges too.
TEST(LodResidency, PrefetchConvergesACameraCutInFewerRounds) {
  Paged p = makePaged(5, 4096);
  const PageTable& t = p.paged.table;
  CutView far = cameraView(p.dag, 40.0f, {1, 0.2f, 0.1f}), near = cameraView(p.dag, 1.05f, {-1, -0.2f, -0.1f});
  far.tau = 16.0f; // the far view holds little more than the roots
  std::vector<uint8_t> roots(t.pages.size(), 0), all(t.pages.size(), 1);
  std::fill(roots.begin(), roots.begin() + t.rootPageCount, 1);
  uint64_t need = rootBytes(t) + bytesOf(t, wantedPages(t, roots, near));
  std::vector<uint32_t> full = selectResidentCut(p.dag, t, all, near).clusters;
  for (uint64_t budget : {uint64_t(1) << 40, need}) {
    uint32_t rounds[2] = {0, 0};
    for (bool prefetch : {false, true}) {
      auto m = ResidencyManager::create(graphOf(t), {budget, 32});
      ASSERT_TRUE(m.ok());
      stream(p, *m, far, 200, prefetch);
      rounds[prefetch] = stream(p, *m, near, 200, prefetch);
      std::vector<uint8_t> resident(m->resident().begin(), m->resident().end());
      EXPECT_TRUE(wantedPages(t, resident, near).empty()) << "prefetch " << prefetch << " budget " << budget;
      EXPECT_EQ(selectResidentCut(p.dag, t, resident, near).clusters, full) << "prefetch " << prefetch;
    }
    EXPECT_LT(rounds[1], rounds[0]) << "budget " << budget;
    EXPECT_GE(rounds[0], 3u) << "the cut needs several levels";
  }
}
