// GVS++ is anytime: cut short by a ray budget at any point from one random batch up, its PVS has
// no more pixel error than RAND's (random rays alone, the same random sequence) at the same rays.
// Three scenes, budgets every half batch from one random batch to 32; then wide cells with large
// batches.
#include <algorithm>

#include <gtest/gtest.h>

#include "mirage/io/generate.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/pvs_eval.h"
#include "vis_scenes.h"

using namespace mirage;
using namespace mirage::vis;

namespace {

struct Case {
  const char* name;
  Scene scene;
  ViewCell cell;
};

// A wide box cell over the middle of a generated city at eye height: many streets and facades in
// view, so a small budget is far from convergence (the situation random rays handle well and a
// bake that spends its budget around its first hits does not).
Case cityCase(const char* name, uint32_t seed, uint64_t size, float fraction) {
  auto scene = io::generateScene("city", seed, size);
  EXPECT_TRUE(scene.ok());
  Case c{name, std::move(*scene), {}};
  Bounds b = c.scene.worldBounds();
  c.cell.position = {b.center().x, 2.0f, b.center().z};
  c.cell.size = {fraction * b.extent().x, 2.0f, fraction * b.extent().z};
  return c;
}

double wrongPixels(RayBackend& backend, const ViewCell& cell, const std::vector<uint32_t>& pvs,
                   uint32_t resolution = 48) {
  TriangleSet set(backend.triangleCount());
  set.assign(pvs);
  EvalConfig ec;
  ec.resolution = resolution;
  ec.haltonViewpoints = 2;
  return evaluatePvs(backend, cell, set, ec).averageWrong;
}

} // namespace

TEST(GvsAnytime, NeverWorseThanRandomAtAnyBudget) {
  std::vector<Case> cases;
  cases.push_back(cityCase("city 1 wide cell", 7, 1, 0.5f));
  cases.push_back(cityCase("city 2 wide cell", 3, 2, 0.3f));
  {
    auto v = test::wallWithHole(); // a backdrop of 800 triangles seen through a hole
    cases.push_back({"wall with hole", std::move(v.scene), v.cell});
  }
  GvsConfig cfg;
  cfg.randomRays = 10'000; // one random batch; budgets from here to 32 batches, every half batch
  cfg.absEdgeSamples = 10;
  cfg.seed = 5;
  cfg.rayBudget = 32 * cfg.randomRays;
  // A bake cut at a budget is the unlimited bake's first rays (BudgetCutsTheSameBake), so one
  // bake's checkpoints stand for a bake per budget.
  BakeOptions budgets;
  for (uint64_t r = cfg.randomRays; r < cfg.rayBudget; r += cfg.randomRays / 2) budgets.checkpointRays.push_back(r);
  for (Case& c : cases) {
    auto backend = createEmbreeBackend(c.scene);
    ASSERT_TRUE(backend.ok()) << backend.error().message;
    CellPvs gvs = computeCellPvs(**backend, c.scene, c.cell, cfg, budgets);
    BakeOptions same;
    for (const PvsCheckpoint& p : gvs.checkpoints) same.checkpointRays.push_back(p.rays);
    CellPvs rnd = computeCellPvs(**backend, c.scene, c.cell, randomOnlyConfig(gvs.stats.rays, cfg.seed), same);
    ASSERT_EQ(rnd.checkpoints.size(), gvs.checkpoints.size());
    // The snapshots, then the final sets (converged below the budget, or at it).
    gvs.checkpoints.push_back({gvs.stats.rays, gvs.triangles});
    rnd.checkpoints.push_back({rnd.stats.rays, rnd.triangles});
    for (size_t i = 0; i < gvs.checkpoints.size(); ++i) {
      const PvsCheckpoint &g = gvs.checkpoints[i], &r = rnd.checkpoints[i];
      ASSERT_EQ(r.rays, g.rays);
      double ge = wrongPixels(**backend, c.cell, g.triangles), re = wrongPixels(**backend, c.cell, r.triangles);
      std::printf("%s: %7llu rays: GVS++ %6zu triangles %8.2f wrong px/view, RAND %6zu triangles %8.2f\n", c.name,
                  (unsigned long long)g.rays, g.triangles.size(), ge, r.triangles.size(), re);
      // Same seed, same random rays: the comparison is what GVS++ does with the rest, exactly.
      EXPECT_LE(ge, re) << c.name << " at " << g.rays << " rays";
    }
  }
}

// Large random batches over wide cells (the command of docs/visibility.md's Measurements, at a
// lower resolution): exploration starts after four batches of 200 k rays, where random rays still
// find a lot, so it must go where a view from anywhere in the cell loses pixels. Valuing finds by
// their solid angle from the discovering ray's origin alone made GVS++ 2-10 % worse than RAND
// from 1 M to 2 M rays. A bake cut at a budget is the unlimited bake's first rays
// (BudgetCutsTheSameBake), so one bake's checkpoints stand for a bake per budget.
TEST(GvsAnytime, WideCellsWithLargeBatchesNeverWorseThanRandom) {
  auto scene = io::generateScene("city", 7, 0);
  ASSERT_TRUE(scene.ok());
  auto backend = createEmbreeBackend(*scene);
  ASSERT_TRUE(backend.ok()) << backend.error().message;
  GvsConfig cfg;
  cfg.randomRays = 200'000;
  cfg.rayBudget = 1'800'000;
  BakeOptions every200k;
  for (uint64_t r = 200'000; r < cfg.rayBudget; r += 200'000) every200k.checkpointRays.push_back(r);
  for (float x : {-30.0f, 30.0f}) { // the two halves of the region -60,1,-60 .. 60,3,60
    ViewCell cell;
    cell.position = {x, 2.0f, 0.0f};
    cell.size = {60.0f, 2.0f, 120.0f};
    CellPvs gvs = computeCellPvs(**backend, *scene, cell, cfg, every200k);
    BakeOptions same;
    for (const PvsCheckpoint& c : gvs.checkpoints) same.checkpointRays.push_back(c.rays);
    CellPvs rnd = computeCellPvs(**backend, *scene, cell, randomOnlyConfig(gvs.stats.rays, cfg.seed), same);
    ASSERT_EQ(rnd.checkpoints.size(), gvs.checkpoints.size());
    for (size_t i = 0; i < gvs.checkpoints.size(); ++i) {
      ASSERT_EQ(rnd.checkpoints[i].rays, gvs.checkpoints[i].rays);
      double ge = wrongPixels(**backend, cell, gvs.checkpoints[i].triangles, 100);
      double re = wrongPixels(**backend, cell, rnd.checkpoints[i].triangles, 100);
      std::printf("cell x %+.0f: %8llu rays: GVS++ %8.2f wrong px/view, RAND %8.2f\n", double(x),
                  (unsigned long long)gvs.checkpoints[i].rays, ge, re);
      EXPECT_LE(ge, re) << "cell at x " << x << ", " << gvs.checkpoints[i].rays << " rays";
    }
  }
}

// The schedule does not depend on the budget: a bake cut at B rays is the unlimited bake's first B
// rays, so --budget trades quality for time along one curve (what pvs-eval --plot draws).
TEST(GvsAnytime, BudgetCutsTheSameBake) {
  auto v = test::wallWithHole();
  auto backend = createEmbreeBackend(v.scene);
  ASSERT_TRUE(backend.ok());
  GvsConfig cfg;
  cfg.randomRays = 5'000;
  cfg.absEdgeSamples = 8;
  cfg.seed = 2;
  CellPvs full = computeCellPvs(**backend, v.scene, v.cell, cfg, {.checkpointRays = {20'000, 45'000}});
  ASSERT_EQ(full.checkpoints.size(), 2u);
  for (const PvsCheckpoint& c : full.checkpoints) {
    GvsConfig cut = cfg;
    cut.rayBudget = c.rays;
    CellPvs part = computeCellPvs(**backend, v.scene, v.cell, cut);
    EXPECT_EQ(part.stats.rays, c.rays);
    EXPECT_EQ(part.triangles, c.triangles);
  }
  // RAND snapshots exactly where GVS++ did (pvs-eval --plot compares the two at equal rays).
  BakeOptions same;
  for (const PvsCheckpoint& c : full.checkpoints) same.checkpointRays.push_back(c.rays);
  CellPvs rnd = computeCellPvs(**backend, v.scene, v.cell, randomOnlyConfig(full.stats.rays, cfg.seed), same);
  ASSERT_EQ(rnd.checkpoints.size(), full.checkpoints.size());
  for (size_t i = 0; i < rnd.checkpoints.size(); ++i) EXPECT_EQ(rnd.checkpoints[i].rays, full.checkpoints[i].rays);
  // Shorter than a step: the first rays of the same random batch.
  GvsConfig tiny = cfg;
  tiny.rayBudget = 777;
  CellPvs a = computeCellPvs(**backend, v.scene, v.cell, tiny);
  CellPvs r = computeCellPvs(**backend, v.scene, v.cell, randomOnlyConfig(777, cfg.seed));
  EXPECT_EQ(a.stats.rays, 777u);
  EXPECT_EQ(a.triangles, r.triangles);
}

// A cell no ray can leave from (coordinates beyond what backends trace) bakes to an empty PVS
// without a ray reaching the backend (Embree asserted on such rays).
TEST(GvsAnytime, UntraceableCellGivesAnEmptyPvs) {
  auto v = test::wallWithHole();
  auto backend = createEmbreeBackend(v.scene);
  ASSERT_TRUE(backend.ok());
  ViewCell far = v.cell;
  far.position = {1e30f, 0.0f, 0.0f};
  GvsConfig cfg;
  cfg.randomRays = 1000;
  cfg.rayBudget = 5000;
  CellPvs pvs = computeCellPvs(**backend, v.scene, far, cfg);
  EXPECT_TRUE(pvs.triangles.empty());
  EXPECT_EQ(pvs.stats.rays, 0u);
}
