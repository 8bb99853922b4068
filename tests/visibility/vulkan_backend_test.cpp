// The Vulkan ray backend against Embree: the same rays hit the same triangles (ties on shared
// edges and coplanar duplicates aside), the record/require sets behave the same, and GVS++ bakes
// on either backend agree within sampling noise. Every test runs on both traversals, the
// ray-tracing pipeline and the compute shader over the host-built BVH. Runs on lavapipe with
// small ray counts.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/vulkan_backend.h"
#include "vis_scenes.h"
#include "../../src/visibility/ray_bvh.h"
#include "../../src/visibility/sampling.h"

using namespace mirage;
using namespace mirage::vis;

using Traversal = VulkanRayOptions::Traversal;

// The ray-tracing pipeline, or the compute traversal over 4-wide or 8-wide (compressed) nodes.
struct TraversalCase {
  Traversal traversal;
  uint32_t bvhWidth;
  const char* name;
};

class VulkanRays : public test::GpuTest, public ::testing::WithParamInterface<TraversalCase> {
protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (GetParam().traversal == Traversal::Pipeline && !context().caps().rayTracingPipeline)
      GTEST_SKIP() << "device has no ray-tracing pipeline";
  }
  std::unique_ptr<VulkanRayBackend> vulkan(const Scene& scene, VulkanRayOptions::Geometry g,
                                           bool persistentThreads = false) {
    VulkanRayOptions o;
    o.geometry = g;
    o.traversal = GetParam().traversal;
    o.bvhWidth = GetParam().bvhWidth;
    o.persistentThreads = persistentThreads;
    o.batchRays = 4096; // several launches per trace: exercises the batching and set mirroring
    auto b = createVulkanBackend(context(), scene, o);
    EXPECT_TRUE(b.ok()) << b.error().message;
    return b.ok() ? std::move(*b) : nullptr;
  }
};

namespace {

std::unique_ptr<RayBackend> embree(const Scene& scene, EmbreeOptions::Geometry g) {
  auto b = createEmbreeBackend(scene, {.geometry = g});
  EXPECT_TRUE(b.ok()) << b.error().message;
  return std::move(*b);
}

// Origins uniform in `box` (and some from the cell), directions uniform on the sphere; a few rays
// with a finite or degenerate interval.
std::vector<Ray> randomRays(const Bounds& box, const ViewCell& cell, size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    Ray& r = rays[i];
    glm::vec3 p(u(rng), u(rng), u(rng));
    r.origin = i % 2 ? glm::mix(box.min, box.max, p) : cell.toWorld(p - 0.5f);
    float z = 1.0f - 2.0f * u(rng), s = std::sqrt(std::max(0.0f, 1.0f - z * z)), phi = 6.2831853f * u(rng);
    r.dir = glm::vec3(s * std::cos(phi), s * std::sin(phi), z) * (0.5f + u(rng)); // t in units of |dir|
    if (i % 17 == 0) r.tfar = 5.0f + 20.0f * u(rng);
    if (i % 101 == 0) r.tnear = 1.0f;
  }
  rays[3].tnear = 2.0f; // inverted interval: a miss on both
  rays[3].tfar = 1.0f;
  return rays;
}

struct Agreement {
  size_t sameTriangle = 0, sameSeeThrough = 0, tieMismatches = 0, n = 0;
};

Agreement compare(const std::vector<Hit>& a, const std::vector<Hit>& b) {
  Agreement g;
  g.n = a.size();
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].triangle == b[i].triangle) {
      ++g.sameTriangle;
      if (a[i].triangle != kNoHit) {
        EXPECT_NEAR(a[i].t, b[i].t, 1e-3f * std::max(1.0f, a[i].t)) << "ray " << i;
      }
    } else if (a[i].triangle != kNoHit && b[i].triangle != kNoHit &&
               std::abs(a[i].t - b[i].t) <= 1e-3f * std::max(1.0f, a[i].t)) {
      ++g.tieMismatches; // same depth, another triangle: an edge or a coplanar duplicate
    }
    g.sameSeeThrough += a[i].seeThrough == b[i].seeThrough;
  }
  return g;
}

} // namespace

TEST_P(VulkanRays, SameHitsAsEmbreeOnRandomRays) {
  auto wall = test::wallWithHole();
  auto room = test::roomWithWindow();
  Scene city = test::cityScene(1);
  struct Case {
    const char* name;
    const Scene* scene;
    ViewCell cell;
  } cases[] = {{"wall", &wall.scene, wall.cell}, {"room", &room.scene, room.cell}, {"city", &city, test::streetCell()}};
  for (const Case& c : cases) {
    for (auto g : {VulkanRayOptions::Geometry::Flatten, VulkanRayOptions::Geometry::Instance}) {
      if (GetParam().traversal == Traversal::Compute && g == VulkanRayOptions::Geometry::Instance)
        continue; // always flat
      SCOPED_TRACE(std::string(c.name) + (g == VulkanRayOptions::Geometry::Flatten ? " flatten" : " instance"));
      auto vk = vulkan(*c.scene, g);
      ASSERT_TRUE(vk);
      auto cpu = embree(*c.scene, g == VulkanRayOptions::Geometry::Flatten ? EmbreeOptions::Geometry::Flatten
                                                                           : EmbreeOptions::Geometry::Instance);
      ASSERT_EQ(vk->triangleCount(), cpu->triangleCount());
      std::vector<Ray> rays = randomRays(c.scene->worldBounds(), c.cell, 20'000, 5);
      std::vector<Hit> a(rays.size()), b(rays.size());
      TriangleSet ra(cpu->triangleCount()), rb(vk->triangleCount());
      cpu->trace(rays, a, {.record = &ra});
      vk->trace(rays, b, {.record = &rb});
      Agreement g2 = compare(a, b);
      size_t hitsSomething =
          size_t(std::count_if(a.begin(), a.end(), [](const Hit& h) { return h.triangle != kNoHit; }));
      EXPECT_GT(hitsSomething, rays.size() / 4) << "rays must mostly hit for the comparison to mean anything";
      EXPECT_GE(double(g2.sameTriangle + g2.tieMismatches), 0.999 * double(g2.n));
      EXPECT_GE(double(g2.sameTriangle), 0.995 * double(g2.n));
      EXPECT_GE(double(g2.sameSeeThrough), 0.999 * double(g2.n));
      EXPECT_EQ(b[3].triangle, kNoHit);
      // Deduplicated where traced: every triangle the rays saw is recorded, and exactly one ray per
      // distinct closest-hit triangle is flagged as its first insertion.
      std::vector<uint32_t> seen;
      size_t flaggedNew = 0;
      for (const Hit& h : b) {
        if (h.triangle != kNoHit) seen.push_back(h.triangle);
        if (h.seeThrough != kNoHit) seen.push_back(h.seeThrough);
        flaggedNew += (h.flags & kHitNew) ? 1 : 0;
      }
      std::sort(seen.begin(), seen.end());
      seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
      for (uint32_t id : seen) ASSERT_TRUE(rb.contains(id));
      std::vector<uint32_t> opaque;
      for (const Hit& h : b)
        if (h.triangle != kNoHit) opaque.push_back(h.triangle);
      std::sort(opaque.begin(), opaque.end());
      opaque.erase(std::unique(opaque.begin(), opaque.end()), opaque.end());
      EXPECT_LE(flaggedNew, opaque.size());
      EXPECT_GE(flaggedNew, opaque.size()) << "a triangle first inserted as see-through cannot be opaque here";
      // The recorded sets differ only by tie-broken triangles.
      std::vector<uint32_t> sa = ra.sorted(), sb = rb.sorted(), diff;
      std::set_symmetric_difference(sa.begin(), sa.end(), sb.begin(), sb.end(), std::back_inserter(diff));
      EXPECT_LE(diff.size(), std::max<size_t>(4, sa.size() / 100));
      // A second trace of the same rays finds nothing new.
      vk->trace(rays, b, {.record = &rb});
      EXPECT_TRUE(
          std::none_of(b.begin(), b.end(), [](const Hit& h) { return h.flags & (kHitNew | kHitSeeThroughNew); }));
    }
  }
}

TEST_P(VulkanRays, RequireAndPvsOnlyTracesMatchEmbree) {
  Scene city = test::cityScene(1);
  auto vk = vulkan(city, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  auto cpu = embree(city, EmbreeOptions::Geometry::Auto);
  // Every third triangle "in the PVS".
  TriangleSet require(cpu->triangleCount());
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < cpu->triangleCount(); i += 3) ids.push_back(i);
  require.assign(ids);
  std::vector<Ray> rays = randomRays(city.worldBounds(), test::streetCell(), 10'000, 9);
  for (bool only : {false, true}) {
    SCOPED_TRACE(only ? "PVS-only" : "full scene");
    std::vector<Hit> a(rays.size()), b(rays.size());
    cpu->trace(rays, a, {.require = &require, .onlyRequired = only});
    vk->trace(rays, b, {.require = &require, .onlyRequired = only});
    size_t sameMissing = 0, inPvs = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      sameMissing += (a[i].flags & kHitMissing) == (b[i].flags & kHitMissing);
      if (only && b[i].triangle != kNoHit) {
        ASSERT_TRUE(require.contains(b[i].triangle));
        ++inPvs;
      }
    }
    EXPECT_GE(double(sameMissing), 0.995 * double(rays.size()));
    Agreement g = compare(a, b);
    EXPECT_GE(double(g.sameTriangle + g.tieMismatches), 0.999 * double(g.n));
    if (only) {
      EXPECT_GT(inPvs, rays.size() / 10);
    }
  }
  // A new assignment of the same set is uploaded again (the device copy must not go stale).
  require.assign(std::vector<uint32_t>{});
  std::vector<Hit> b(rays.size());
  vk->trace(rays, b, {.require = &require, .onlyRequired = true});
  EXPECT_TRUE(std::all_of(b.begin(), b.end(), [](const Hit& h) { return h.triangle == kNoHit; }));
}

TEST_P(VulkanRays, GvsBakesAgreeWithEmbree) {
  GvsConfig cfg;
  cfg.randomRays = 20'000;
  cfg.absEdgeSamples = 10;
  cfg.seed = 3;
  {
    auto v = test::wallWithHole();
    auto vk = vulkan(v.scene, VulkanRayOptions::Geometry::Auto);
    ASSERT_TRUE(vk);
    CellPvs pvs = computeCellPvs(*vk, v.scene, v.cell, cfg);
    auto has = [&](const std::string& mesh) {
      size_t n = 0;
      for (uint32_t id : test::meshTriangles(v.scene, mesh))
        n += std::binary_search(pvs.triangles.begin(), pvs.triangles.end(), id);
      return n;
    };
    EXPECT_EQ(has("target"), test::meshTriangles(v.scene, "target").size());
    EXPECT_EQ(has("hidden"), 0u);
    EXPECT_GT(has("backdrop"), 0u);
  }
  Scene city = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto vk = vulkan(city, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  auto cpu = embree(city, EmbreeOptions::Geometry::Auto);
  CellPvs a = computeCellPvs(*cpu, city, cell, cfg);
  CellPvs b = computeCellPvs(*vk, city, cell, cfg);
  // Sampling noise: the same bake on Embree with another seed. Tie-breaking differences send the
  // Vulkan bake down other sampling paths, so it must agree with Embree about as well as that.
  GvsConfig other = cfg;
  other.seed = 4;
  CellPvs c = computeCellPvs(*cpu, city, cell, other);
  auto common = [](const CellPvs& x, const CellPvs& y) {
    std::vector<uint32_t> both;
    std::set_intersection(x.triangles.begin(), x.triangles.end(), y.triangles.begin(), y.triangles.end(),
                          std::back_inserter(both));
    return double(both.size());
  };
  std::printf("city cell: Embree %zu triangles (%llu rays), Vulkan %zu (%llu rays), Embree seed 4 %zu; shared: "
              "Embree/Vulkan %.0f, Embree/Embree seed 4 %.0f\n",
              a.triangles.size(), (unsigned long long)a.stats.rays, b.triangles.size(),
              (unsigned long long)b.stats.rays, c.triangles.size(), common(a, b), common(a, c));
  const double n = double(a.triangles.size());
  EXPECT_NEAR(double(b.triangles.size()), n, 0.1 * n);
  EXPECT_GE(common(a, b), common(a, c) - 0.03 * n);
  EXPECT_GE(common(a, b), 0.97 * common(a, c));
  EXPECT_TRUE(b.stats.generatedRandomRays); // the random phase ran in the raygen shader
  EXPECT_FALSE(a.stats.generatedRandomRays);
}

// The raygen shader's cell rays are the host sampler's rays: traced through trace() with the
// host's lowest-ray crediting, they give the same discoveries as traceCellRays.
TEST_P(VulkanRays, CellRaysMatchHostMadeRays) {
  Scene city = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto vk = vulkan(city, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  detail::RandomizedHalton<5> halton(5);
  detail::SurfaceSampler surface(cell);
  const size_t n = 20'000;
  const uint64_t first = (uint64_t(1) << 32) - 5000; // crosses the shader's 32/64-bit switch
  std::vector<Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    auto h = halton(first + i);
    rays[i].origin = surface.point(h[0], h[1], h[2]);
    rays[i].dir = detail::sphereDirection(h[3], h[4]);
  }
  TriangleSet hostSet(vk->triangleCount()), deviceSet(vk->triangleCount());
  std::vector<Hit> hits(n);
  vk->trace(rays, hits, {.record = &hostSet});
  std::map<uint32_t, uint32_t> hostFirst; // triangle -> lowest ray whose closest/see-through hit it is
  for (size_t i = 0; i < n; ++i)
    for (uint32_t t : {hits[i].triangle, hits[i].seeThrough})
      if (t != kNoHit) hostFirst.emplace(t, uint32_t(i));
  CellRaySource source{surface.faces, surface.cdf, halton.offsets(), first};
  std::vector<FirstHit> found;
  ASSERT_TRUE(vk->traceCellRays(source, n, deviceSet, found));
  std::map<uint32_t, uint32_t> deviceFirst;
  for (const FirstHit& f : found) {
    EXPECT_TRUE(deviceFirst.emplace(f.triangle, f.ray).second) << "triangle " << f.triangle << " reported twice";
    EXPECT_LT(f.ray, n);
    EXPECT_TRUE(deviceSet.contains(f.triangle));
  }
  size_t same = 0;
  for (auto [t, ray] : hostFirst) {
    auto it = deviceFirst.find(t);
    same += it != deviceFirst.end() && it->second == ray;
  }
  std::printf("cell rays: host %zu discoveries, device %zu, same triangle and ray %zu\n", hostFirst.size(),
              deviceFirst.size(), same);
  // Float rounding of the Halton points differs between host and shader; a few rays graze edges.
  EXPECT_GE(double(same), 0.98 * double(hostFirst.size()));
  EXPECT_NEAR(double(deviceFirst.size()), double(hostFirst.size()), 0.02 * double(hostFirst.size()));
  EXPECT_NEAR(double(deviceSet.count()), double(hostSet.count()), 0.02 * double(hostSet.count()));
  // Again into the same set: nothing new. Into a fresh set: exactly the same discoveries.
  std::vector<FirstHit> again;
  ASSERT_TRUE(vk->traceCellRays(source, n, deviceSet, again));
  EXPECT_TRUE(again.empty());
  TriangleSet fresh(vk->triangleCount());
  ASSERT_TRUE(vk->traceCellRays(source, n, fresh, again));
  auto key = [](const FirstHit& a, const FirstHit& b) { return a.triangle < b.triangle; };
  std::sort(found.begin(), found.end(), key);
  std::sort(again.begin(), again.end(), key);
  ASSERT_EQ(again.size(), found.size());
  for (size_t i = 0; i < found.size(); ++i) {
    EXPECT_EQ(again[i].triangle, found[i].triangle);
    EXPECT_EQ(again[i].ray, found[i].ray);
  }
  EXPECT_EQ(fresh.sorted(), deviceSet.sorted());
}

TEST_P(VulkanRays, GeneratedBakesAreReproducible) {
  Scene city = test::cityScene(1);
  auto vk = vulkan(city, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  GvsConfig cfg;
  cfg.randomRays = 5'000;
  cfg.absEdgeSamples = 4;
  cfg.seed = 9;
  CellPvs a = computeCellPvs(*vk, city, test::streetCell(), cfg);
  CellPvs b = computeCellPvs(*vk, city, test::streetCell(), cfg);
  EXPECT_TRUE(a.stats.generatedRandomRays);
  EXPECT_GT(a.triangles.size(), 100u);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.stats.rays, b.stats.rays);
}

TEST_P(VulkanRays, GeneratedRaysFromACellSeeOnlyWhatTheCellSees) {
  auto v = test::wallWithHole();
  auto vk = vulkan(v.scene, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  Bounds box;
  for (glm::vec3 p : v.cell.corners()) box.add(p);
  TriangleSet found(vk->triangleCount());
  vk->traceGenerated(box.min, box.max, 200'000, 1, &found);
  auto count = [&](const std::string& mesh) {
    size_t n = 0;
    for (uint32_t id : test::meshTriangles(v.scene, mesh)) n += found.contains(id);
    return n;
  };
  EXPECT_EQ(count("hidden"), 0u);
  EXPECT_GT(count("target"), 0u);
  EXPECT_GT(count("wall"), 0u);
  // The same stream again: nothing new, and the same set from a fresh start.
  size_t before = found.count();
  vk->traceGenerated(box.min, box.max, 200'000, 1, &found);
  EXPECT_EQ(found.count(), before);
  TriangleSet again(vk->triangleCount());
  vk->traceGenerated(box.min, box.max, 200'000, 1, &again);
  EXPECT_EQ(again.sorted(), found.sorted());
  EXPECT_GT(vk->lastTiming().wallMilliseconds, 0.0);
}

// Glass in front of a wall and glass behind it: every ray reports the wall, the nearest front pane
// as its see-through triangle, records the panes it passed and never the pane behind the wall.
TEST_P(VulkanRays, SeeThroughTrianglesCountOnlyInFrontOfTheWall) {
  auto v = test::glassPanes();
  auto vk = vulkan(v.scene, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  auto cpu = embree(v.scene, EmbreeOptions::Geometry::Flatten);
  std::vector<Ray> rays(4000);
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (Ray& r : rays) {
    r.origin = v.cell.toWorld(glm::vec3(u(rng), u(rng), u(rng)) * 0.5f);
    r.dir = glm::vec3(0.3f * u(rng), 0.3f * u(rng), 1.0f);
  }
  std::vector<Hit> a(rays.size()), b(rays.size());
  TriangleSet ra(cpu->triangleCount()), rb(vk->triangleCount());
  cpu->trace(rays, a, {.record = &ra});
  vk->trace(rays, b, {.record = &rb});
  auto ids = [&](const char* mesh) { return test::meshTriangles(v.scene, mesh); };
  auto in = [](const std::vector<uint32_t>& set, uint32_t id) {
    return std::find(set.begin(), set.end(), id) != set.end();
  };
  const auto wall = ids("wall"), front = ids("front"), behind = ids("behind");
  // The nearest pane (z = 1) holds the first third of the front mesh's triangles.
  const std::vector<uint32_t> nearest(front.begin(), front.begin() + std::ptrdiff_t(front.size() / 3));
  size_t seeThroughNew = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_TRUE(in(wall, b[i].triangle)) << "ray " << i;
    ASSERT_TRUE(in(nearest, b[i].seeThrough)) << "ray " << i;
    EXPECT_NEAR(b[i].t, 5.0f - rays[i].origin.z, 1e-3f); // dir.z = 1: t is the z distance
    seeThroughNew += (b[i].flags & kHitSeeThroughNew) != 0;
  }
  EXPECT_EQ(compare(a, b).sameSeeThrough, rays.size());
  for (uint32_t id : behind) EXPECT_FALSE(rb.contains(id));
  for (size_t pane = 0; pane < 3; ++pane) { // the panes behind the nearest are recorded too
    size_t recorded = 0;
    for (size_t k = pane * front.size() / 3; k < (pane + 1) * front.size() / 3; ++k) recorded += rb.contains(front[k]);
    EXPECT_GT(recorded, 0u) << "pane " << pane;
  }
  EXPECT_EQ(ra.sorted(), rb.sorted());
  EXPECT_GT(seeThroughNew, 0u);
}

// Rays with the interval [0, inf) (every GVS++ ray) travel as 24-byte (origin, direction) pairs;
// they hit exactly what the same rays sent as 32-byte rays hit, in every traversal.
TEST_P(VulkanRays, CompactRaysHitWhatFullRaysHit) {
  Scene city = test::cityScene(1);
  std::vector<Ray> rays = randomRays(city.worldBounds(), test::streetCell(), 10'000, 13);
  for (Ray& r : rays) r = Ray{.origin = r.origin, .dir = r.dir}; // the default interval
  auto vk = vulkan(city, VulkanRayOptions::Geometry::Auto);
  ASSERT_TRUE(vk);
  std::vector<Hit> compact(rays.size()), full(rays.size());
  TriangleSet compactSet(vk->triangleCount()), fullSet(vk->triangleCount());
  vk->trace(rays, compact, {.record = &compactSet});
  vk->setCompactRays(false);
  vk->trace(rays, full, {.record = &fullSet});
  size_t hit = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(compact[i].triangle, full[i].triangle) << "ray " << i;
    ASSERT_EQ(compact[i].t, full[i].t) << "ray " << i;
    ASSERT_EQ(compact[i].seeThrough, full[i].seeThrough) << "ray " << i;
    hit += full[i].triangle != kNoHit;
  }
  EXPECT_GT(hit, rays.size() / 4);
  EXPECT_EQ(compactSet.sorted(), fullSet.sorted());
}

// The compute traversal's variants: persistent threads, a shared-memory stack and staged rays
// change the schedule or where rays live, not the rays' results; spatial splits and 4- or 8-wide
// nodes change the tree, so only ties may differ.
TEST_P(VulkanRays, ComputeVariantsTraceTheSameHits) {
  if (GetParam().traversal != Traversal::Compute || GetParam().bvhWidth != 4)
    GTEST_SKIP() << "compute traversal options";
  Scene city = test::cityScene(1);
  std::vector<Ray> rays = randomRays(city.worldBounds(), test::streetCell(), 20'000, 7);
  auto run = [&](VulkanRayOptions o, TriangleSet& record) {
    o.traversal = Traversal::Compute;
    o.batchRays = 4096;
    auto b = createVulkanBackend(context(), city, o);
    EXPECT_TRUE(b.ok()) << b.error().message;
    std::vector<Hit> hits(rays.size());
    if (b.ok()) (*b)->trace(rays, hits, {.record = &record});
    return hits;
  };
  const size_t n = triangleOffsets(city).back();
  TriangleSet plainSet(n), persistentSet(n), sharedSet(n), splitSet(n), wideSet(n), widePersistentSet(n), bvh8Set(n),
      bvh8PersistentSet(n), stagedSet(n), postponeSet(n);
  std::vector<Hit> plain = run({.bvhWidth = 2}, plainSet);
  std::vector<Hit> persistent = run({.persistentThreads = true, .bvhWidth = 2}, persistentSet);
  std::vector<Hit> shared = run({.sharedStack = true, .bvhWidth = 2}, sharedSet);
  std::vector<Hit> split = run({.spatialSplits = true, .bvhWidth = 2}, splitSet);
  std::vector<Hit> wide = run({.bvhWidth = 4}, wideSet);
  std::vector<Hit> widePersistent = run({.persistentThreads = true, .bvhWidth = 4}, widePersistentSet);
  std::vector<Hit> bvh8 = run({.bvhWidth = 8}, bvh8Set);
  std::vector<Hit> bvh8Persistent = run({.persistentThreads = true, .bvhWidth = 8}, bvh8PersistentSet);
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(wide[i].triangle, widePersistent[i].triangle) << "ray " << i;
    ASSERT_EQ(wide[i].t, widePersistent[i].t) << "ray " << i;
    ASSERT_EQ(bvh8[i].triangle, bvh8Persistent[i].triangle) << "ray " << i;
    ASSERT_EQ(bvh8[i].t, bvh8Persistent[i].t) << "ray " << i;
  }
  EXPECT_EQ(bvh8Set.sorted(), bvh8PersistentSet.sorted());
  // Staged rays (device-local copies) trace exactly what the shader reading host memory traces.
  std::vector<Hit> staged = run({.bvhWidth = 8, .stagedRays = true}, stagedSet);
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(bvh8[i].triangle, staged[i].triangle) << "ray " << i;
    ASSERT_EQ(bvh8[i].t, staged[i].t) << "ray " << i;
    ASSERT_EQ(bvh8[i].seeThrough, staged[i].seeThrough) << "ray " << i;
  } // (not the flags: which of several rays inserts a new triangle first depends on thread timing)
  EXPECT_EQ(bvh8Set.sorted(), stagedSet.sorted());
  for (const std::vector<Hit>* other : {&persistent, &shared}) {
    for (size_t i = 0; i < rays.size(); ++i) {
      ASSERT_EQ(plain[i].triangle, (*other)[i].triangle) << "ray " << i;
      ASSERT_EQ(plain[i].seeThrough, (*other)[i].seeThrough) << "ray " << i;
      ASSERT_EQ(plain[i].t, (*other)[i].t) << "ray " << i;
    }
  }
  EXPECT_EQ(plainSet.sorted(), persistentSet.sorted());
  EXPECT_EQ(plainSet.sorted(), sharedSet.sorted());
  std::vector<Hit> postpone = run({.bvhWidth = 8, .postponeTriangles = true}, postponeSet);
  for (const std::vector<Hit>* other : {&split, &wide, &bvh8, &postpone}) {
    Agreement g = compare(plain, *other);
    EXPECT_GE(double(g.sameTriangle + g.tieMismatches), 0.9995 * double(g.n));
    EXPECT_GE(double(g.sameSeeThrough), 0.999 * double(g.n));
  }
}

// The 8-wide compressed BVH bakes the PVS the 4-wide one does: RAND (the same rays, no feedback)
// gives the same set up to triangles reached only through depth ties; GVS++ (whose border and
// reverse rays follow what earlier rays hit, so one tie sends the sampling down another path)
// agrees within the noise of the same bake with another seed. 8-wide on the city street cell:
// RAND 2,122 of 2,123 shared; GVS++ 3,624 shared of 3,678 / 3,648.
class VulkanBvh8 : public test::GpuTest {};

TEST_F(VulkanBvh8, BakesTheSamePvsAsTheFourWideTraversal) {
  Scene city = test::cityScene(1);
  ViewCell cell = test::streetCell();
  auto backend = [&](uint32_t width) {
    auto b = createVulkanBackend(context(), city, {.traversal = Traversal::Compute, .bvhWidth = width});
    EXPECT_TRUE(b.ok()) << b.error().message;
    return std::move(*b);
  };
  auto wide4 = backend(4), wide8 = backend(8);
  auto common = [](const CellPvs& x, const CellPvs& y) {
    std::vector<uint32_t> both;
    std::set_intersection(x.triangles.begin(), x.triangles.end(), y.triangles.begin(), y.triangles.end(),
                          std::back_inserter(both));
    return double(both.size());
  };
  GvsConfig rand = randomOnlyConfig(200'000, 5);
  CellPvs r4 = computeCellPvs(*wide4, city, cell, rand), r8 = computeCellPvs(*wide8, city, cell, rand);
  GvsConfig cfg;
  cfg.randomRays = 20'000;
  cfg.absEdgeSamples = 10;
  cfg.seed = 3;
  CellPvs g4 = computeCellPvs(*wide4, city, cell, cfg), g8 = computeCellPvs(*wide8, city, cell, cfg);
  std::printf("RAND: 4-wide %zu, 8-wide %zu triangles, %.0f shared; GVS++: 4-wide %zu, 8-wide %zu, %.0f shared\n",
              r4.triangles.size(), r8.triangles.size(), common(r4, r8), g4.triangles.size(), g8.triangles.size(),
              common(g4, g8));
  EXPECT_EQ(r4.stats.rays, r8.stats.rays);
  EXPECT_GE(common(r4, r8), 0.998 * double(r4.triangles.size()));
  EXPECT_GE(common(r4, r8), 0.998 * double(r8.triangles.size()));
  // The 4-wide bake with seed 4 instead of 3 shares 95.7% of the seed-3 set (measured; a third
  // bake here would double the test's time): the two trees must agree at least that well.
  const double n = double(g4.triangles.size());
  EXPECT_NEAR(double(g8.triangles.size()), n, 0.05 * n);
  EXPECT_GE(common(g4, g8), 0.957 * n);
}

namespace {

// The host-built BVH of the compute traversal: every triangle is in a leaf, leaves are well
// formed, every leaf triangle touches its box, and the depth fits the shader's stack.
void checkBvh(const Scene& city, bool splits, uint32_t width) {
  auto bvh = detail::buildRayBvh(city, {.spatialSplits = splits, .width = width});
  ASSERT_TRUE(bvh.ok()) << bvh.error().message;
  std::printf("compute BVH of gen:city:1 (splits %d, width %u): %zu triangles, %zu nodes, %zu leaf triangles, depth "
              "%u, %.3f s\n",
              int(splits), width, size_t(triangleOffsets(city).back()), bvh->nodes.size() + bvh->nodes4.size(),
              bvh->triangles.size(), bvh->depth, bvh->buildSeconds);
  const size_t nodes = width == 4 ? bvh->nodes4.size() : bvh->nodes.size();
  ASSERT_GT(nodes, 0u);
  EXPECT_EQ(width == 4 ? bvh->nodes.size() : bvh->nodes4.size(), 0u);
  EXPECT_LE(bvh->depth * (width - 1), uint32_t(MIRAGE_RT_BVH_STACK - 2)); // the pushes fit the shader's stack
  std::vector<bool> seen(triangleOffsets(city).back(), false);
  size_t leaves = 0, inner = 0;
  auto visit = [&](uint32_t ref, glm::vec3 lo, glm::vec3 hi) {
    if (!(ref & MIRAGE_RT_BVH_LEAF)) {
      ASSERT_LT(ref, nodes);
      ++inner;
      return;
    }
    ++leaves;
    for (uint32_t k = ref & ~MIRAGE_RT_BVH_LEAF;; ++k) {
      ASSERT_LT(k, bvh->triangles.size());
      const shaderio::RtBvhTriangle& t = bvh->triangles[k];
      ASSERT_LT(t.id, seen.size());
      seen[t.id] = true;
      glm::vec3 tlo = glm::min(glm::min(t.v0, t.v1), t.v2), thi = glm::max(glm::max(t.v0, t.v1), t.v2);
      EXPECT_TRUE(glm::all(glm::lessThanEqual(lo, thi)) && glm::all(glm::lessThanEqual(tlo, hi)))
          << "triangle " << t.id << " outside its leaf box";
      if (t.flags & MIRAGE_RT_BVH_LAST) break;
    }
  };
  for (const shaderio::RtBvhNode& n : bvh->nodes) {
    visit(n.child0, n.lo0, {n.hi0x, n.hi0y, n.hi0z});
    visit(n.child1, {n.lo1x, n.lo1y, n.lo1z}, {n.hi1x, n.hi1y, n.hi1z});
  }
  size_t wideChildren = 0;
  for (const shaderio::RtBvh4Node& n : bvh->nodes4)
    for (int c = 0; c < 4; ++c) {
      if (n.child[c] == MIRAGE_RT_BVH_NONE) continue;
      ++wideChildren;
      visit(n.child[c], {n.loX[c], n.loY[c], n.loZ[c]}, {n.hiX[c], n.hiY[c], n.hiZ[c]});
    }
  if (width == 4) {
    EXPECT_GT(double(wideChildren), 3.0 * double(nodes)); // mostly full nodes
  }
  EXPECT_EQ(inner + 1, nodes); // a tree: every node but the root is someone's child
  EXPECT_EQ(size_t(std::count(seen.begin(), seen.end(), true)), seen.size());
  EXPECT_GT(leaves, seen.size() / 4); // leaves of at most 4 triangles (plus split references)
}

} // namespace

TEST(ComputeBvh, LeavesCoverEveryTriangleWithinTheirBoxes) {
  Scene city = test::cityScene(1);
  for (bool splits : {false, true})
    for (uint32_t width : {2u, 4u}) {
      SCOPED_TRACE(std::string(splits ? "spatial splits" : "binned SAH") + ", width " + std::to_string(width));
      checkBvh(city, splits, width);
    }
}

INSTANTIATE_TEST_SUITE_P(Traversals, VulkanRays,
                         ::testing::Values(TraversalCase{Traversal::Pipeline, 4, "Pipeline"},
                                           TraversalCase{Traversal::Compute, 4, "Compute"},
                                           TraversalCase{Traversal::Compute, 8, "ComputeBvh8"}),
                         [](const ::testing::TestParamInfo<TraversalCase>& param) { return param.param.name; });
