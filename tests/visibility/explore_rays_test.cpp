// GVS++ exploration rays made on the device (traceExploreRays, MODE_BORDER / MODE_REVERSE): the
// shader makes the host's rays (shaderio/gvs_explore.h, read back and compared slot by slot within
// float tolerance), reports the discontinuities the host's test finds on the same hits, and bakes
// of equal quality (pixel error) to the host-made rays. On both traversals; lavapipe, small counts.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/pvs_eval.h"
#include "mirage/visibility/vulkan_backend.h"
#include "vis_scenes.h"
#include "../../src/visibility/explore_rays.h"
#include "../../src/visibility/sampling.h"

using namespace mirage;
using namespace mirage::vis;

using Traversal = VulkanRayOptions::Traversal;

class ExploreRays : public test::GpuTest, public ::testing::WithParamInterface<Traversal> {
protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (GetParam() == Traversal::Pipeline && !context().caps().rayTracingPipeline)
      GTEST_SKIP() << "device has no ray-tracing pipeline";
  }
  std::unique_ptr<VulkanRayBackend> vulkan(const Scene& scene, bool exploreOnDevice = true) {
    VulkanRayOptions o;
    o.traversal = GetParam();
    o.exploreOnDevice = exploreOnDevice;
    o.batchRays = 1 << 14;
    auto b = createVulkanBackend(context(), scene, o);
    EXPECT_TRUE(b.ok()) << b.error().message;
    return b.ok() ? std::move(*b) : nullptr;
  }
};

namespace {

// Slot by slot: skipped on both, or the same origin and direction within float tolerance (the
// shader's normalize, sqrt and Halton digits round differently). A few slots may be decided
// differently where a shadow test or a degenerate check sits on its threshold.
void expectSameRays(const std::vector<Ray>& host, const std::vector<Ray>& device, float scale, const char* what) {
  ASSERT_EQ(host.size(), device.size());
  size_t traced = 0, sameSkip = 0, close = 0;
  for (size_t i = 0; i < host.size(); ++i) {
    const bool h = host[i].tfar >= 0.0f, d = device[i].tfar >= 0.0f;
    traced += h;
    if (h != d) continue;
    ++sameSkip;
    if (!h) continue;
    const float o = glm::length(host[i].origin - device[i].origin), dir = glm::length(host[i].dir - device[i].dir);
    close += o <= 1e-5f * scale && dir <= 1e-5f;
    if (o > 1e-5f * scale || dir > 1e-5f)
      ADD_FAILURE() << what << " slot " << i << ": origin off by " << o << ", direction by " << dir;
  }
  std::printf("%s: %zu slots, %zu traced on the host, skip decided alike %zu, rays equal %zu\n", what, host.size(),
              traced, sameSkip, close);
  EXPECT_GT(traced, host.size() / 4);
  EXPECT_GE(double(sameSkip), 0.999 * double(host.size()));
}

} // namespace

// ABS and RS rays read back from the shader equal the host sampler's (makeExploreRays), and the
// discontinuities the shader reports are those the host's test finds on the device's hits.
TEST_P(ExploreRays, DeviceRaysAreTheHostFormulas) {
  Scene scene = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto vk = vulkan(scene);
  ASSERT_TRUE(vk);
  const std::vector<uint64_t> offsets = triangleOffsets(scene);
  const float scale = glm::length(scene.worldBounds().extent());

  // Discoveries to border-sample: what random rays from the cell find first.
  detail::RandomizedHalton<5> halton(11);
  detail::SurfaceSampler surface(cell);
  std::vector<Ray> random(4000);
  for (size_t i = 0; i < random.size(); ++i) {
    auto h = halton(i);
    random[i].origin = surface.point(h[0], h[1], h[2]);
    random[i].dir = detail::sphereDirection(h[3], h[4]);
  }
  std::vector<Hit> hits(random.size());
  TriangleSet seen(vk->triangleCount());
  vk->trace(random, hits, {.record = &seen});
  std::vector<ExploreRaySource::BorderItem> border;
  std::set<uint32_t> taken;
  for (size_t i = 0; i < random.size() && border.size() < 300; ++i)
    if (hits[i].triangle != kNoHit && taken.insert(hits[i].triangle).second)
      border.push_back({random[i].origin, hits[i].triangle});
  ASSERT_GT(border.size(), 100u);

  const std::vector<std::array<glm::vec3, 2>> edges = cell.edges();
  ExploreRaySource src;
  src.border = border;
  src.raysPerItem = 9 + 3 * 6;
  src.absEdgeSamples = 6;
  src.absDeltaTriangle = 1e-3f;
  src.absDeltaAbsolute = 1e-5f * scale;
  src.rsDeltaRelative = 0.02f;
  src.edges = edges;
  src.faces = surface.faces;
  src.cdf = surface.cdf;
  std::vector<Ray> hostRays(border.size() * src.raysPerItem);
  std::vector<glm::vec3> targets(hostRays.size());
  detail::makeExploreRays(scene, offsets, src, hostRays, targets);
  std::vector<Ray> deviceRays;
  ExploreResult abs{.rays = &deviceRays};
  TriangleSet record(vk->triangleCount());
  ASSERT_TRUE(vk->traceExploreRays(src, record, abs));
  expectSameRays(hostRays, deviceRays, scale, "ABS");
  EXPECT_EQ(abs.traced,
            size_t(std::count_if(deviceRays.begin(), deviceRays.end(), [](const Ray& r) { return r.tfar >= 0.0f; })));
  EXPECT_FALSE(abs.firstHits.empty());
  for (const FirstHit& f : abs.firstHits) EXPECT_TRUE(record.contains(f.triangle));

  // The host's discontinuity test on the device's own rays, traced through trace().
  std::vector<Ray> traced;
  std::vector<uint32_t> slotOf;
  for (size_t i = 0; i < deviceRays.size(); ++i)
    if (deviceRays[i].tfar >= 0.0f) {
      traced.push_back(deviceRays[i]);
      slotOf.push_back(uint32_t(i));
    }
  std::vector<Hit> absHits(traced.size());
  vk->trace(traced, absHits, {});
  std::set<uint32_t> hostSeeds, deviceSeeds;
  for (size_t i = 0; i < traced.size(); ++i) {
    const float dist = glm::length(targets[slotOf[i]] - traced[i].origin);
    if (absHits[i].triangle == kNoHit || absHits[i].t < dist * (1.0f - src.rsDeltaRelative))
      hostSeeds.insert(slotOf[i]);
  }
  for (const Discontinuity& d : abs.discontinuities) {
    EXPECT_TRUE(deviceSeeds.insert(d.ray).second) << "ray " << d.ray << " reported twice";
    ASSERT_LT(d.ray, targets.size());
    EXPECT_LE(glm::length(d.target - targets[d.ray]), 1e-5f * scale);
  }
  std::vector<uint32_t> both;
  std::set_intersection(hostSeeds.begin(), hostSeeds.end(), deviceSeeds.begin(), deviceSeeds.end(),
                        std::back_inserter(both));
  std::printf("discontinuities: host test %zu, shader %zu, both %zu\n", hostSeeds.size(), deviceSeeds.size(),
              both.size());
  ASSERT_GT(hostSeeds.size(), 50u);
  EXPECT_EQ(both.size(), hostSeeds.size());
  EXPECT_EQ(both.size(), deviceSeeds.size());

  // RS from those discontinuities; sequence indices that cross 2^32 in the Halton points (the
  // shader's 32- to 64-bit switch).
  std::vector<ExploreRaySource::ReverseItem> reverse;
  for (const Discontinuity& d : abs.discontinuities) reverse.push_back({d.target, d.occluder});
  ExploreRaySource rs = src;
  rs.kind = ExploreRaySource::Kind::Reverse;
  rs.border = {};
  rs.reverse = reverse;
  rs.rsEdgeSamples = 7;
  rs.rsAreaSamples = 9;
  rs.raysPerItem = 16;
  rs.rsOffset = {0.25f, 0.5f, 0.75f};
  rs.firstSeed = (uint64_t(1) << 32) / rs.rsAreaSamples - reverse.size() / 2;
  std::vector<Ray> hostRs(reverse.size() * rs.raysPerItem), deviceRs;
  detail::makeExploreRays(scene, offsets, rs, hostRs, {});
  ExploreResult rsOut{.rays = &deviceRs};
  ASSERT_TRUE(vk->traceExploreRays(rs, record, rsOut));
  expectSameRays(hostRs, deviceRs, scale, "RS");
  EXPECT_TRUE(rsOut.discontinuities.empty());
  // A discovering ray rebuilt on the host (exploreRay) is the ray the device traced in that slot.
  for (const FirstHit& f : rsOut.firstHits) {
    ASSERT_LT(f.ray, deviceRs.size());
    Ray r = detail::exploreRay(scene, offsets, rs, f.ray);
    EXPECT_LE(glm::length(r.origin - deviceRs[f.ray].origin), 1e-5f * scale);
  }
}

// The same bake with the rays made on the device and on the host: equal quality (pixel error within
// the noise of a change of seed), the device bake reproducible.
TEST_P(ExploreRays, DeviceExplorationBakesAsWellAsTheHost) {
  Scene scene = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto device = vulkan(scene, true);
  auto host = vulkan(scene, false);
  ASSERT_TRUE(device && host);
  GvsConfig cfg;
  cfg.randomRays = 20'000;
  cfg.absEdgeSamples = 10;
  cfg.rsEdgeSamples = 6;
  cfg.rsAreaSamples = 6;
  cfg.seed = 3;
  GvsConfig other = cfg;
  other.seed = 4;
  CellPvs d = computeCellPvs(*device, scene, cell, cfg);
  CellPvs h = computeCellPvs(*host, scene, cell, cfg);
  CellPvs h4 = computeCellPvs(*host, scene, cell, other);
  CellPvs again = computeCellPvs(*device, scene, cell, cfg);
  EXPECT_EQ(d.triangles, again.triangles);
  EXPECT_EQ(d.stats.rays, again.stats.rays);
  EXPECT_GT(d.stats.absRays, 0u);
  EXPECT_GT(d.stats.rsRays, 0u);
  auto wrong = [&](const CellPvs& pvs) {
    TriangleSet set(host->triangleCount());
    set.assign(pvs.triangles);
    EvalConfig ec;
    ec.resolution = 64;
    ec.haltonViewpoints = 2;
    return evaluatePvs(*host, cell, set, ec).averageWrong;
  };
  const double ed = wrong(d), eh = wrong(h), eh4 = wrong(h4);
  std::printf("wrong pixels per view: device-made rays %.2f (%zu triangles, %llu rays), host-made %.2f (%zu, %llu), "
              "host seed 4 %.2f\n",
              ed, d.triangles.size(), (unsigned long long)d.stats.rays, eh, h.triangles.size(),
              (unsigned long long)h.stats.rays, eh4);
  const double noise = std::abs(eh - eh4);
  EXPECT_LE(ed, std::max(eh, eh4) + noise + 0.1);
  EXPECT_NEAR(double(d.triangles.size()), double(h.triangles.size()), 0.05 * double(h.triangles.size()));
}

// Launches queued back to back (a bake keeps one in flight while it takes in the one before) find
// exactly what the same synchronous calls find in that order: each sees the set the ones before it
// left, and each reads back into its own buffers.
TEST_P(ExploreRays, QueuedTracesFindWhatSynchronousCallsFind) {
  Scene scene = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto vk = vulkan(scene);
  ASSERT_TRUE(vk);
  ASSERT_EQ(vk->maxQueued(), 2u);
  const float scale = glm::length(scene.worldBounds().extent());
  detail::RandomizedHalton<5> halton(7);
  detail::SurfaceSampler surface(cell);
  const size_t n = 20'000;
  CellRaySource a{surface.faces, surface.cdf, halton.offsets(), 0}, b = a;
  b.firstIndex = n;
  // A border chunk around what some other random rays find first.
  std::vector<Ray> random(2000);
  for (size_t i = 0; i < random.size(); ++i) {
    auto h = halton(2 * n + i);
    random[i].origin = surface.point(h[0], h[1], h[2]);
    random[i].dir = detail::sphereDirection(h[3], h[4]);
  }
  std::vector<Hit> hits(random.size());
  TriangleSet seen(vk->triangleCount());
  vk->trace(random, hits, {.record = &seen});
  std::vector<ExploreRaySource::BorderItem> items;
  std::set<uint32_t> taken;
  for (size_t i = 0; i < random.size() && items.size() < 200; ++i)
    if (hits[i].triangle != kNoHit && taken.insert(hits[i].triangle).second)
      items.push_back({random[i].origin, hits[i].triangle});
  ASSERT_GT(items.size(), 50u);
  ExploreRaySource border;
  border.border = items;
  border.raysPerItem = 9 + 3 * 6;
  border.absEdgeSamples = 6;
  border.absDeltaTriangle = 1e-3f;
  border.absDeltaAbsolute = 1e-5f * scale;
  border.rsDeltaRelative = 0.02f;

  // Synchronous: random rays A, the border chunk, random rays B.
  TriangleSet syncSet(vk->triangleCount());
  std::vector<ExploreResult> sync(3);
  ASSERT_TRUE(vk->traceCellRays(a, n, syncSet, sync[0].firstHits));
  ASSERT_TRUE(vk->traceExploreRays(border, syncSet, sync[1]));
  ASSERT_TRUE(vk->traceCellRays(b, n, syncSet, sync[2].firstHits));
  // Queued: at most two at once, collected in order.
  TriangleSet queuedSet(vk->triangleCount());
  std::vector<ExploreResult> queued(3);
  ASSERT_TRUE(vk->submitCellRays(a, n, queuedSet));
  ASSERT_TRUE(vk->submitExploreRays(border, queuedSet));
  EXPECT_FALSE(vk->submitCellRays(b, n, queuedSet)); // the queue is full
  vk->collect(queuedSet, queued[0]);
  ASSERT_TRUE(vk->submitCellRays(b, n, queuedSet));
  vk->collect(queuedSet, queued[1]);
  vk->collect(queuedSet, queued[2]);

  auto byRay = [](const auto& x, const auto& y) { return x.ray != y.ray ? x.ray < y.ray : x.triangle < y.triangle; };
  for (size_t k = 0; k < 3; ++k) {
    for (ExploreResult* r : {&sync[k], &queued[k]}) {
      std::sort(r->firstHits.begin(), r->firstHits.end(), byRay);
      std::sort(r->discontinuities.begin(), r->discontinuities.end(),
                [](const Discontinuity& x, const Discontinuity& y) { return x.ray < y.ray; });
    }
    EXPECT_FALSE(queued[k].firstHits.empty()) << "launch " << k;
    ASSERT_EQ(queued[k].firstHits.size(), sync[k].firstHits.size()) << "launch " << k;
    for (size_t i = 0; i < sync[k].firstHits.size(); ++i) {
      EXPECT_EQ(queued[k].firstHits[i].triangle, sync[k].firstHits[i].triangle);
      EXPECT_EQ(queued[k].firstHits[i].ray, sync[k].firstHits[i].ray);
    }
    ASSERT_EQ(queued[k].discontinuities.size(), sync[k].discontinuities.size()) << "launch " << k;
    for (size_t i = 0; i < sync[k].discontinuities.size(); ++i) {
      EXPECT_EQ(queued[k].discontinuities[i].ray, sync[k].discontinuities[i].ray);
      EXPECT_EQ(queued[k].discontinuities[i].occluder, sync[k].discontinuities[i].occluder);
    }
  }
  EXPECT_EQ(queued[0].traced, n);
  EXPECT_EQ(queued[1].traced, sync[1].traced);
  EXPECT_FALSE(queued[1].discontinuities.empty());
  EXPECT_EQ(queuedSet.sorted(), syncSet.sorted());
}

// With a step in flight, a bake with checkpoints or a budget takes the step in before sizing the
// next, on exact counts, but chooses as the unlimited bake does: the same bake, cut where asked.
TEST_P(ExploreRays, QueuedBakesCutTheSameBake) {
  Scene scene = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto vk = vulkan(scene);
  ASSERT_TRUE(vk);
  GvsConfig cfg;
  cfg.randomRays = 10'000;
  cfg.absEdgeSamples = 6;
  cfg.rsEdgeSamples = 4;
  cfg.rsAreaSamples = 4;
  cfg.seed = 5;
  CellPvs plain = computeCellPvs(*vk, scene, cell, cfg);
  CellPvs full = computeCellPvs(*vk, scene, cell, cfg, {.checkpointRays = {60'000, 150'000}});
  EXPECT_TRUE(plain.stats.generatedExploreRays);
  EXPECT_GT(plain.stats.rsRays, 0u);
  EXPECT_EQ(full.triangles, plain.triangles);
  EXPECT_EQ(full.stats.rays, plain.stats.rays);
  EXPECT_EQ(full.stats.absRays, plain.stats.absRays);
  EXPECT_EQ(full.stats.rsRays, plain.stats.rsRays);
  ASSERT_EQ(full.checkpoints.size(), 2u);
  for (const PvsCheckpoint& c : full.checkpoints) {
    GvsConfig cut = cfg;
    cut.rayBudget = c.rays;
    CellPvs part = computeCellPvs(*vk, scene, cell, cut);
    EXPECT_EQ(part.stats.rays, c.rays);
    // The chunk that reaches the budget is made on the host (cut ray by ray), whose rays agree
    // with the device's to float rounding: a grazing ray may find another triangle.
    std::vector<uint32_t> both;
    std::set_intersection(part.triangles.begin(), part.triangles.end(), c.triangles.begin(), c.triangles.end(),
                          std::back_inserter(both));
    EXPECT_GE(double(both.size()), 0.99 * double(c.triangles.size()));
    EXPECT_NEAR(double(part.triangles.size()), double(c.triangles.size()), 0.01 * double(c.triangles.size()));
  }
}

// Lanes (RayBackend::sibling): cells baked at once on two threads, each on its own lane over the
// scene built once, find exactly what one lane finds baking them one after the other (a lane's
// sets, first rays and launches are its own; the device's queue and command pools are shared).
TEST_P(ExploreRays, LanesBakeCellsAtOnceAsOneLaneDoes) {
  Scene scene = test::cityScene(1);
  std::vector<ViewCell> cells = {test::streetCell(), test::streetCell(), test::streetCell()};
  cells[1].position.z += 6.0f;
  cells[2].position = {-2.0f, 1.7f, -20.0f};
  auto vk = vulkan(scene);
  ASSERT_TRUE(vk);
  std::unique_ptr<RayBackend> lane = vk->sibling();
  ASSERT_TRUE(lane);
  EXPECT_EQ(lane->name(), vk->name());
  EXPECT_EQ(lane->triangleCount(), vk->triangleCount());
  GvsConfig cfg;
  cfg.randomRays = 10'000;
  cfg.absEdgeSamples = 6;
  cfg.rsEdgeSamples = 4;
  cfg.rsAreaSamples = 4;
  cfg.rayBudget = 120'000;
  std::vector<CellPvs> alone;
  for (const ViewCell& c : cells) alone.push_back(computeCellPvs(*vk, scene, c, cfg));
  // Lane 0 takes cells 0 and 2, lane 1 cell 1, at the same time.
  std::vector<CellPvs> lanes(cells.size());
  std::thread other([&] { lanes[1] = computeCellPvs(*lane, scene, cells[1], cfg); });
  lanes[0] = computeCellPvs(*vk, scene, cells[0], cfg);
  lanes[2] = computeCellPvs(*vk, scene, cells[2], cfg);
  other.join();
  for (size_t i = 0; i < cells.size(); ++i) {
    EXPECT_TRUE(lanes[i].stats.generatedExploreRays);
    EXPECT_EQ(lanes[i].triangles, alone[i].triangles) << "cell " << i;
    EXPECT_EQ(lanes[i].stats.rays, alone[i].stats.rays) << "cell " << i;
    EXPECT_EQ(lanes[i].stats.absRays, alone[i].stats.absRays) << "cell " << i;
    EXPECT_EQ(lanes[i].stats.rsRays, alone[i].stats.rsRays) << "cell " << i;
  }
  EXPECT_NE(alone[0].triangles, alone[2].triangles); // the cells see different things
}

INSTANTIATE_TEST_SUITE_P(Traversals, ExploreRays, ::testing::Values(Traversal::Pipeline, Traversal::Compute),
                         [](const ::testing::TestParamInfo<Traversal>& p) {
                           return p.param == Traversal::Pipeline ? "Pipeline" : "Compute";
                         });
