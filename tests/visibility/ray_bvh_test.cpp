// The compute traversal's compressed 8-wide BVH on the CPU: the quantized node encoding (every
// decoded child box contains the child's exact box, and not by much more than one quantization
// step), the tree's structure, and a CPU replica of the shader's traversal against Embree, so the
// encoding and the visiting order are checked without a GPU.
#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mirage/io/generate.h"
#include "mirage/visibility/ray_backend.h"
#include "vis_scenes.h"
#include "../../src/visibility/ray_bvh.h"

using namespace mirage;
using namespace mirage::vis;

namespace {

Scene cityScene(uint32_t blocks) {
  auto scene = io::generateScene("city", 4, blocks);
  EXPECT_TRUE(scene.ok());
  return std::move(*scene);
}

struct Box {
  glm::dvec3 lo{INFINITY}, hi{-INFINITY};
  void add(glm::dvec3 p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void add(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
};

uint32_t metaOf(const shaderio::RtBvh8Node& n, uint32_t slot) { return (n.meta[slot / 4] >> (8 * (slot % 4))) & 0xffu; }

// Walks node `index`: checks each slot's decoded box against the exact box of what lies below it
// (the triangles' corners, no padding) and returns the node's exact box.
struct Checker {
  const detail::RayBvh& bvh;
  std::vector<uint32_t> seen; // times each global ID appears in a leaf
  size_t nodes = 0, children = 0;
  double worstSlack = 0.0; // largest decoded - exact gap, in quantization steps (padding excluded)
  double pad = 0.0;

  Box walk(uint32_t index, uint32_t depth) {
    EXPECT_LT(index, bvh.nodes8.size());
    EXPECT_LE(depth, bvh.depth);
    const shaderio::RtBvh8Node& n = bvh.nodes8[index];
    ++nodes;
    Box all;
    uint32_t innerRank = 0, nextTriangle = 0;
    for (uint32_t s = 0; s < 8; ++s) {
      const uint32_t meta = metaOf(n, s);
      const bool inner = (n.exponents >> (24 + s)) & 1u;
      if (meta == 0) {
        EXPECT_FALSE(inner);
        continue;
      }
      ++children;
      Box exact;
      if (inner) {
        EXPECT_EQ(meta, MIRAGE_RT_BVH8_INNER_META + s) << "slot " << s;
        exact = walk(n.childBase + innerRank++, depth + 1);
      } else {
        const uint32_t unary = meta >> 5, offset = meta & 31u;
        EXPECT_TRUE(unary == 1 || unary == 3 || unary == 7) << "meta " << meta;
        EXPECT_EQ(offset, nextTriangle) << "leaves' triangles are consecutive in slot order";
        const uint32_t count = uint32_t(std::popcount(unary));
        EXPECT_LE(offset + count, 24u);
        nextTriangle = offset + count;
        for (uint32_t k = 0; k < count; ++k) {
          const shaderio::RtBvhTriangle& t = bvh.triangles.at(n.triangleBase + offset + k);
          ++seen.at(t.id);
          for (glm::vec3 v : {t.v0, t.v1, t.v2}) exact.add(glm::dvec3(v));
        }
      }
      glm::dvec3 lo, hi;
      detail::decodeBvh8Box(n, s, lo, hi);
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(lo[a], exact.lo[a]) << "slot " << s << " axis " << a;
        EXPECT_GE(hi[a], exact.hi[a]) << "slot " << s << " axis " << a;
        const double step = std::ldexp(1.0, int((n.exponents >> (8 * a)) & 0xffu) - 127);
        worstSlack = std::max({worstSlack, (exact.lo[a] - lo[a] - pad) / step, (hi[a] - exact.hi[a] - pad) / step});
      }
      all.add(exact);
    }
    return all;
  }
};

} // namespace

TEST(ComputeBvh8, QuantizedBoxesContainTheirChildrenAndEveryTriangleOnce) {
  Scene scene = cityScene(1);
  auto bvh = detail::buildRayBvh(scene, {.width = 8});
  ASSERT_TRUE(bvh.ok()) << bvh.error().message;
  EXPECT_TRUE(bvh->nodes.empty() && bvh->nodes4.empty());
  ASSERT_FALSE(bvh->nodes8.empty());
  EXPECT_LE(bvh->depth + 1, uint32_t(MIRAGE_RT_BVH8_STACK)); // one push per level fits the stack
  const size_t triangles = triangleOffsets(scene).back();
  Checker c{*bvh, std::vector<uint32_t>(triangles, 0)};
  const Bounds world = scene.worldBounds();
  const glm::vec3 far = glm::max(glm::abs(world.min), glm::abs(world.max));
  c.pad = std::max({far.x, far.y, far.z}) * 0x1p-21;
  c.walk(0, 1);
  std::printf("8-wide BVH of gen:city:1: %zu triangles, %zu nodes, %.2f children per node, %zu leaf triangles, "
              "depth %u, worst slack %.3f steps\n",
              triangles, c.nodes, double(c.children) / double(c.nodes), bvh->triangles.size(), bvh->depth,
              c.worstSlack);
  EXPECT_EQ(c.nodes, bvh->nodes8.size()); // a tree: every node reached once
  EXPECT_TRUE(std::all_of(c.seen.begin(), c.seen.end(), [](uint32_t n) { return n == 1; }));
  EXPECT_EQ(bvh->triangles.size(), triangles);
  EXPECT_GT(double(c.children), 5.0 * double(c.nodes)); // wide nodes, mostly full
  EXPECT_LE(c.worstSlack, 1.0 + 1e-9);                  // outward rounding costs at most one step per side
}

// Spatial splits clip references: boxes then hold the clipped parts, so only the structure and
// the replica's hits are checked; a scene of one triangle is a root with one leaf slot.
TEST(ComputeBvh8, SpatialSplitsAndASingleTriangle) {
  Scene scene = cityScene(1);
  auto split = detail::buildRayBvh(scene, {.spatialSplits = true, .width = 8});
  ASSERT_TRUE(split.ok());
  EXPECT_GT(split->triangles.size(), triangleOffsets(scene).back()); // some references split
  auto one = test::wallWithHole();
  one.scene.meshes[0].indices.resize(3);
  one.scene.instances.resize(1);
  auto tiny = detail::buildRayBvh(one.scene, {.width = 8});
  ASSERT_TRUE(tiny.ok());
  ASSERT_EQ(tiny->nodes8.size(), 1u);
  ASSERT_EQ(tiny->triangles.size(), 1u);
  const shaderio::RtBvhTriangle& t = tiny->triangles[0];
  glm::vec3 centre = (t.v0 + t.v1 + t.v2) / 3.0f, normal = glm::normalize(glm::cross(t.v1 - t.v0, t.v2 - t.v0));
  for (float side : {1.0f, -1.0f}) {
    detail::CpuTraceResult r = detail::cpuTrace(*tiny, centre + side * normal, -side * normal, 0.0f, INFINITY);
    EXPECT_EQ(r.triangle, t.id);
    EXPECT_NEAR(r.t, 1.0f, 1e-4f);
  }
  EXPECT_EQ(detail::cpuTrace(*tiny, centre + normal, normal, 0.0f, INFINITY).triangle, MIRAGE_RT_NO_HIT);
}

// The replica of the shaders' traversals (4- and 8-wide, with and without spatial splits) finds
// Embree's closest triangle, ties at the same depth aside, with the GPU tests' tolerances.
TEST(ComputeBvh8, CpuReplicaFindsEmbreesClosestHits) {
  Scene scene = cityScene(1);
  auto embree = createEmbreeBackend(scene, {.geometry = EmbreeOptions::Geometry::Flatten});
  ASSERT_TRUE(embree.ok());
  const Bounds box = scene.worldBounds();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Ray> rays(20'000);
  for (Ray& r : rays) {
    r.origin = glm::mix(box.min, box.max, glm::vec3(u(rng), u(rng), u(rng)));
    float z = 1.0f - 2.0f * u(rng), s = std::sqrt(std::max(0.0f, 1.0f - z * z)), phi = 6.2831853f * u(rng);
    r.dir = glm::vec3(s * std::cos(phi), s * std::sin(phi), z);
  }
  std::vector<Hit> reference(rays.size());
  (*embree)->trace(rays, reference, {});
  struct Case {
    uint32_t width;
    bool splits;
  };
  for (Case c : {Case{4, false}, Case{8, false}, Case{8, true}}) {
    SCOPED_TRACE("width " + std::to_string(c.width) + (c.splits ? " with spatial splits" : ""));
    auto bvh = detail::buildRayBvh(scene, {.spatialSplits = c.splits, .width = c.width});
    ASSERT_TRUE(bvh.ok());
    size_t same = 0, tied = 0, sameSeeThrough = 0, hits = 0;
    double nodes = 0, tests = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      detail::CpuTraceResult r = detail::cpuTrace(*bvh, rays[i].origin, rays[i].dir, rays[i].tnear, rays[i].tfar);
      const Hit& e = reference[i];
      hits += e.triangle != kNoHit;
      same += r.triangle == e.triangle;
      tied += r.triangle != e.triangle && r.triangle != kNoHit && e.triangle != kNoHit &&
              std::abs(r.t - e.t) <= 1e-3f * std::max(1.0f, e.t);
      sameSeeThrough += r.seeThrough == e.seeThrough;
      nodes += r.nodes;
      tests += r.triangleTests;
    }
    std::printf("CPU replica, width %u%s: same closest triangle %.4f%%, or tied %.4f%%; %.1f nodes and %.1f "
                "triangle tests per ray\n",
                c.width, c.splits ? " (splits)" : "", 100.0 * double(same) / double(rays.size()),
                100.0 * double(same + tied) / double(rays.size()), nodes / double(rays.size()),
                tests / double(rays.size()));
    EXPECT_GT(hits, rays.size() / 4);
    EXPECT_GE(double(same), 0.995 * double(rays.size()));
    EXPECT_GE(double(same + tied), 0.999 * double(rays.size()));
    EXPECT_GE(double(sameSeeThrough), 0.999 * double(rays.size()));
  }
}
