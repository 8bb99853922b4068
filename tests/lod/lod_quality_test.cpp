// Quality: symmetric surface distance (mean of both one-sided mean point-to-surface distances over
// area-uniform samples, as in the dissertation's Eq. 10) of DAG cuts. On real data against a
// meshopt_simplify chain at equal triangle counts (prints; disabled by default, it takes minutes on
// the dragon):
//   build/tests/test_lod --gtest_also_run_disabled_tests --gtest_filter='LodQuality.*'
// and on generated meshes as a regression bound (in CI).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <unordered_map>

#include <gtest/gtest.h>

#include <cstdlib>
#include <meshoptimizer.h>

#include "lod_meshes.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/verify.h"
#include "test_support.h"

namespace mirage::lod {
namespace {

using Tri = std::array<glm::vec3, 3>;

// Closest point on triangle (Ericson, Real-Time Collision Detection 5.1.5), squared distance.
float distance2(glm::vec3 p, const Tri& t) {
  glm::vec3 a = t[0], b = t[1], c = t[2], ab = b - a, ac = c - a, ap = p - a;
  float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  auto len2 = [](glm::vec3 v) { return glm::dot(v, v); };
  if (d1 <= 0 && d2 <= 0) return len2(ap);
  glm::vec3 bp = p - b;
  float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return len2(bp);
  float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return len2(p - (a + ab * (d1 / (d1 - d3))));
  glm::vec3 cp = p - c;
  float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return len2(cp);
  float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return len2(p - (a + ac * (d2 / (d2 - d6))));
  float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return len2(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
  float denom = 1.0f / (va + vb + vc);
  return len2(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

// Uniform grid of triangles for nearest-surface queries.
class Grid {
public:
  explicit Grid(const std::vector<Tri>& tris) : tris_(tris) {
    for (const Tri& t : tris)
      for (const glm::vec3& p : t) box_.add(p);
    cell_ = std::max(glm::length(box_.extent()) / std::cbrt(float(tris.size())) * 0.5f, 1e-6f);
    for (uint32_t i = 0; i < tris.size(); ++i) {
      glm::ivec3 lo = cellOf(glm::min(glm::min(tris[i][0], tris[i][1]), tris[i][2]));
      glm::ivec3 hi = cellOf(glm::max(glm::max(tris[i][0], tris[i][1]), tris[i][2]));
      for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
          for (int x = lo.x; x <= hi.x; ++x) cells_[key({x, y, z})].push_back(i);
    }
  }
  float distance(glm::vec3 p) const {
    glm::ivec3 c = cellOf(p);
    float best = 1e30f;
    for (int r = 0; r < 4096; ++r) {
      for (int z = -r; z <= r; ++z)
        for (int y = -r; y <= r; ++y)
          for (int x = -r; x <= r; ++x) {
            if (std::max({std::abs(x), std::abs(y), std::abs(z)}) != r) continue; // shell only
            auto it = cells_.find(key(c + glm::ivec3(x, y, z)));
            if (it == cells_.end()) continue;
            for (uint32_t t : it->second) best = std::min(best, distance2(p, tris_[t]));
          }
      if (best < 1e30f && std::sqrt(best) <= float(r) * cell_) break; // nothing closer further out
    }
    return std::sqrt(best);
  }

private:
  glm::ivec3 cellOf(glm::vec3 p) const { return glm::ivec3(glm::floor((p - box_.min) / cell_)); }
  static uint64_t key(glm::ivec3 c) {
    return (uint64_t(uint32_t(c.x) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y) & 0x1fffff) << 21) |
           (uint64_t(uint32_t(c.z) & 0x1fffff));
  }
  const std::vector<Tri>& tris_;
  Bounds box_;
  float cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

// Mean distance from area-uniform samples of `from` to the surface `to`.
double oneSided(const std::vector<Tri>& from, const Grid& to, uint32_t samples, uint32_t seed) {
  std::vector<double> cdf;
  double total = 0.0;
  for (const Tri& t : from) cdf.push_back(total += 0.5 * glm::length(glm::cross(t[1] - t[0], t[2] - t[0])));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double sum = 0.0;
  for (uint32_t i = 0; i < samples; ++i) {
    size_t t =
        std::min(size_t(std::lower_bound(cdf.begin(), cdf.end(), u(rng) * total) - cdf.begin()), from.size() - 1);
    float r1 = std::sqrt(float(u(rng))), r2 = float(u(rng));
    glm::vec3 p = from[t][0] * (1 - r1) + from[t][1] * (r1 * (1 - r2)) + from[t][2] * (r1 * r2);
    sum += to.distance(p);
  }
  return sum / samples;
}

double symmetricDistance(const std::vector<Tri>& a, const std::vector<Tri>& b) {
  Grid ga(a), gb(b);
  return 0.5 * (oneSided(a, gb, 40000, 1) + oneSided(b, ga, 40000, 2));
}

std::vector<Tri> cutTriangles(const ClusterDag& dag, const std::vector<uint32_t>& cut) {
  std::vector<Tri> out;
  for (uint32_t c : cut) {
    const Cluster& cl = dag.clusters[c];
    for (uint32_t t = 0; t < cl.triangleCount; ++t) {
      Tri tri;
      for (int k = 0; k < 3; ++k)
        tri[k] =
            dag.positions[dag.vertexPosition[dag.clusterVertices[cl.vertexOffset +
                                                                 dag.clusterIndices[(cl.triangleOffset + t) * 3 + k]]]];
      out.push_back(tri);
    }
  }
  return out;
}

std::vector<Tri> meshTriangles(const Mesh& m, const std::vector<uint32_t>& indices) {
  std::vector<Tri> out;
  for (size_t i = 0; i < indices.size(); i += 3)
    out.push_back({m.positions[indices[i]], m.positions[indices[i + 1]], m.positions[indices[i + 2]]});
  return out;
}

// Triangle shapes: the fraction with a smallest angle under 10 degrees (slivers, slow to
// rasterize) and the mean aspect ratio (longest edge over the shortest altitude, scaled so that an
// equilateral triangle has 1).
struct Shapes {
  double sliverFraction = 0.0, meanAspect = 0.0;
};
Shapes triangleShapes(const std::vector<Tri>& tris) {
  Shapes s;
  size_t n = 0;
  for (const Tri& t : tris) {
    double area2 = glm::length(glm::dvec3(glm::cross(t[1] - t[0], t[2] - t[0])));
    if (!(area2 > 0.0)) continue;
    double l2[3], minSin2 = 1.0;
    for (int k = 0; k < 3; ++k) l2[k] = glm::dot(glm::dvec3(t[(k + 1) % 3] - t[k]), glm::dvec3(t[(k + 1) % 3] - t[k]));
    for (int k = 0; k < 3; ++k) // the angle between edges k and k+2 at corner k: sin = area2 / (|a| |b|)
      minSin2 = std::min(minSin2, area2 * area2 / (l2[k] * l2[(k + 2) % 3]));
    double smallest = std::asin(std::sqrt(std::min(minSin2, 1.0)));
    s.sliverFraction += smallest < 10.0 * 3.14159265358979 / 180.0;
    double longest = std::max({l2[0], l2[1], l2[2]});
    s.meanAspect += longest / area2 * (std::sqrt(3.0) / 2.0); // longest / altitude on it, equilateral 1
    ++n;
  }
  if (n) s.sliverFraction /= double(n), s.meanAspect /= double(n);
  return s;
}

struct CutQuality {
  size_t triangles = 0;
  double distance = 0.0;
  Shapes shapes;
};

// The DAG cut at the smallest group error threshold with at most `fraction` of the input's
// triangles, and its symmetric distance to the input.
CutQuality cutQuality(const Mesh& mesh, const ClusterDag& dag, const std::vector<Tri>& original, double fraction) {
  std::vector<float> errors;
  for (const Group& g : dag.groups) errors.push_back(g.bounds.error);
  std::sort(errors.begin(), errors.end());
  size_t goal = size_t(double(mesh.triangleCount()) * fraction);
  std::vector<uint32_t> cut;
  CutQuality q;
  for (float e : errors) {
    cut = selectCut(dag, e);
    q.triangles = 0;
    for (uint32_t c : cut) q.triangles += dag.clusters[c].triangleCount;
    if (q.triangles <= goal) break;
  }
  std::vector<Tri> tris = cutTriangles(dag, cut);
  q.distance = symmetricDistance(original, tris);
  q.shapes = triangleShapes(tris);
  return q;
}

constexpr double kFractions[3] = {0.25, 1.0 / 16, 1.0 / 64};

// MIRAGE_LOD_QUALITY_MESH picks another ascii PLY under ../shared/data (default: the bunny), e.g.
// stanford-dragon/dragon_vrip.ply.
TEST(LodQuality, DISABLED_CutVersusSimplifyChain) {
  const char* which = std::getenv("MIRAGE_LOD_QUALITY_MESH");
  MIRAGE_REQUIRE_DATA(path, which ? which : "stanford-bunny/bun_zipper.ply");
  Mesh mesh = *lodtest::readAsciiPly(path);
  BuildConfig cfg;
  if (const char* env = std::getenv("MIRAGE_LOD_NORMAL_WEIGHT")) cfg.normalWeight = float(std::atof(env));
  if (const char* env = std::getenv("MIRAGE_LOD_GROUP_CLUSTERS")) cfg.groupClusters = uint32_t(std::atoi(env));
  Result<ClusterDag> dag = buildClusterDag(mesh, cfg);
  ASSERT_TRUE(dag.ok());
  std::vector<Tri> original = meshTriangles(mesh, mesh.indices);
  for (double fraction : kFractions) {
    CutQuality q = cutQuality(mesh, *dag, original, fraction);
    std::vector<uint32_t> simplified(mesh.indices.size());
    simplified.resize(meshopt_simplify(simplified.data(), mesh.indices.data(), mesh.indices.size(),
                                       &mesh.positions[0].x, mesh.positions.size(), sizeof(glm::vec3), q.triangles * 3,
                                       1.0f, 0, nullptr));
    double dChain = symmetricDistance(original, meshTriangles(mesh, simplified));
    std::printf("%s at %zu triangles (%.1f %%): DAG cut %.4g, meshopt_simplify %zu tris %.4g (x bbox diag %.3g); "
                "cut shapes: %.1f %% under 10 degrees, mean aspect %.2f\n",
                path.filename().c_str(), q.triangles, 100.0 * double(q.triangles) / double(mesh.triangleCount()),
                q.distance, simplified.size() / 3, dChain, double(mesh.bounds.radius() * 2.0f),
                100.0 * q.shapes.sliverFraction, q.shapes.meanAspect);
    EXPECT_GT(q.distance, 0.0);
  }
  Shapes root = triangleShapes(cutTriangles(*dag, dag->roots));
  size_t rootTriangles = 0;
  for (uint32_t c : dag->roots) rootTriangles += dag->clusters[c].triangleCount;
  std::printf("%s root: %zu clusters, %zu triangles, %.1f %% with an angle under 10 degrees, mean aspect %.2f\n",
              path.filename().c_str(), dag->roots.size(), rootTriangles, 100.0 * root.sliverFraction, root.meanAspect);
}

// Regression guard on generated meshes (CI speed): the geometric-error cuts at 25 / 6.2 / 1.6 %
// stay within 5 % of the distances measured when the grouping and border weights were tuned
// (groups of 16 with border weight 4 gave, in the same order, blob 7.95e-4 / 3.37e-3 / 1.16e-2 and
// terrain 4.38e-3 / 7.07e-3 / 1.00e-2).
TEST(LodQuality, GeneratedMeshCutsDoNotRegress) {
  struct Case {
    Mesh mesh;
    double bound[3];
  };
  Case cases[] = {{lodtest::makeBlob(5, 1), {7.43e-4, 3.03e-3, 1.149e-2}},
                  {lodtest::makeTerrain(100, 2), {4.22e-3, 6.92e-3, 8.77e-3}}};
  for (const Case& c : cases) {
    BuildConfig cfg;
    cfg.normalWeight = 0.0f;
    Result<ClusterDag> dag = buildClusterDag(c.mesh, cfg);
    ASSERT_TRUE(dag.ok());
    std::vector<Tri> original = meshTriangles(c.mesh, c.mesh.indices);
    for (int i = 0; i < 3; ++i) {
      CutQuality q = cutQuality(c.mesh, *dag, original, kFractions[i]);
      std::printf("%s %.1f %%: %zu triangles, distance %.4g\n", c.mesh.name.c_str(), 100.0 * kFractions[i], q.triangles,
                  q.distance);
      EXPECT_LE(q.distance, c.bound[i] * 1.05) << c.mesh.name << " at " << kFractions[i];
    }
  }
}

} // namespace
} // namespace mirage::lod
