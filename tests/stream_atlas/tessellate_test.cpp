// Tessellation of large triangles (stream/tessellate.h): the refined mesh is watertight where the
// source was (no T-junctions, also across seams of split vertices), covers the same area, carries
// attributes interpolated barycentrically, and has no edge longer than the limit; limits and bad
// configurations are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "mirage/io/import.h"
#include "mirage/stream/patches.h"
#include "mirage/stream/tessellate.h"
#include "test_scenes.h"
#include "test_support.h"

namespace mirage::stream {
namespace {

// Vertices welded by their exact position bits: what a rasterizer sees as one point.
std::vector<uint32_t> weldedIds(const Mesh& mesh) {
  std::map<std::tuple<uint32_t, uint32_t, uint32_t>, uint32_t> ids;
  std::vector<uint32_t> out;
  for (const glm::vec3& p : mesh.positions) {
    uint32_t bits[3];
    std::memcpy(bits, &p, sizeof(bits));
    out.push_back(ids.emplace(std::make_tuple(bits[0], bits[1], bits[2]), uint32_t(ids.size())).first->second);
  }
  return out;
}

// Edges (welded, undirected) used by exactly one triangle: their count and total length. A
// T-junction leaves the long edge and its pieces each used once.
struct Boundary {
  size_t edges = 0;
  double length = 0;
};
Boundary boundaryOf(const Mesh& mesh) {
  std::vector<uint32_t> id = weldedIds(mesh);
  std::map<std::pair<uint32_t, uint32_t>, std::pair<int, double>> uses;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    for (int k = 0; k < 3; ++k) {
      uint32_t a = mesh.indices[3 * t + k], b = mesh.indices[3 * t + (k + 1) % 3];
      if (id[a] == id[b]) continue;
      auto& use = uses[{std::min(id[a], id[b]), std::max(id[a], id[b])}];
      use.first++;
      use.second = glm::length(glm::dvec3(mesh.positions[b]) - glm::dvec3(mesh.positions[a]));
    }
  }
  Boundary boundary;
  for (const auto& [edge, use] : uses) {
    if (use.first != 1) continue;
    boundary.edges++;
    boundary.length += use.second;
  }
  return boundary;
}

double triangleArea(const Mesh& mesh, size_t t) {
  glm::dvec3 a = mesh.positions[mesh.indices[3 * t]], b = mesh.positions[mesh.indices[3 * t + 1]],
             c = mesh.positions[mesh.indices[3 * t + 2]];
  return 0.5 * glm::length(glm::cross(b - a, c - a));
}

double area(const Mesh& mesh) {
  double sum = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) sum += triangleArea(mesh, t);
  return sum;
}

double longestEdge(const Mesh& mesh) {
  double longest = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t)
    for (int k = 0; k < 3; ++k)
      longest = std::max<double>(longest, glm::length(mesh.positions[mesh.indices[3 * t + (k + 1) % 3]] -
                                                      mesh.positions[mesh.indices[3 * t + k]]));
  return longest;
}

// Random attributes on every vertex (normals not unit: interpolation must not renormalize them).
void randomAttributes(Mesh& mesh, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  size_t n = mesh.positions.size();
  mesh.normals.resize(n), mesh.tangents.resize(n), mesh.uv0.resize(n), mesh.colors.resize(n);
  for (size_t v = 0; v < n; ++v) {
    mesh.normals[v] = {u(rng), u(rng), u(rng)};
    mesh.tangents[v] = {u(rng), u(rng), u(rng), u(rng) < 0 ? -1.0f : 1.0f};
    mesh.uv0[v] = {u(rng) * 4.0f, u(rng) * 4.0f};
    mesh.colors[v] = {u(rng) * 0.5f + 0.5f, u(rng) * 0.5f + 0.5f, u(rng) * 0.5f + 0.5f, u(rng) * 0.5f + 0.5f};
  }
}

// A closed polyhedron with shared vertices: an octahedron subdivided twice, vertex radii and the
// whole shape stretched so its triangles differ in size and shape.
Mesh closedPolyhedron(uint32_t seed) {
  Mesh m;
  m.name = "polyhedron";
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  for (int level = 0; level < 2; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto [it, fresh] = mid.emplace(std::make_pair(std::min(a, b), std::max(a, b)), uint32_t(m.positions.size()));
      if (fresh) m.positions.push_back(glm::normalize(m.positions[a] + m.positions[b]));
      return it->second;
    };
    std::vector<uint32_t> next;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
      uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
    }
    m.indices = std::move(next);
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> radius(0.7f, 1.3f);
  for (glm::vec3& p : m.positions) p *= radius(rng) * glm::vec3(7.0f, 2.0f, 4.0f);
  randomAttributes(m, seed);
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

// The same mesh with every triangle's vertices its own (a seam along every edge), each copy with
// its own attributes: crack-freeness must come from positions alone.
Mesh unwelded(const Mesh& mesh, uint32_t seed) {
  Mesh m = mesh;
  m.positions.clear();
  m.indices.clear();
  for (uint32_t index : mesh.indices) {
    m.indices.push_back(uint32_t(m.positions.size()));
    m.positions.push_back(mesh.positions[index]);
  }
  randomAttributes(m, seed);
  return m;
}

// Every output vertex of every output triangle against the barycentric interpolation of its
// source triangle's attributes, at the vertex's barycentric coordinates (from positions).
void expectInterpolated(const Mesh& source, const Mesh& refined, const std::vector<uint32_t>& sourceTriangle) {
  ASSERT_EQ(sourceTriangle.size(), refined.triangleCount());
  size_t checked = 0;
  for (size_t t = 0; t < refined.triangleCount(); ++t) {
    const uint32_t* s = &source.indices[3 * size_t(sourceTriangle[t])];
    glm::dvec3 a = source.positions[s[0]], b = source.positions[s[1]], c = source.positions[s[2]];
    glm::dvec3 e1 = b - a, e2 = c - a;
    double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2), det = d11 * d22 - d12 * d12;
    for (int k = 0; k < 3; ++k) {
      uint32_t v = refined.indices[3 * t + k];
      glm::dvec3 p = glm::dvec3(refined.positions[v]) - a;
      double y = (d22 * glm::dot(p, e1) - d12 * glm::dot(p, e2)) / det;
      double z = (d11 * glm::dot(p, e2) - d12 * glm::dot(p, e1)) / det;
      double x = 1.0 - y - z;
      // In the source triangle's plane and inside it.
      glm::dvec3 back = x * a + y * b + z * c;
      EXPECT_LT(glm::length(back - glm::dvec3(refined.positions[v])), 1e-4) << "triangle " << t;
      EXPECT_GE(std::min({x, y, z}), -1e-5) << "triangle " << t;
      auto expectNear = [&](auto got, auto x0, auto x1, auto x2, const char* what) {
        auto want = double(x) * decltype(got)(x0) + double(y) * decltype(got)(x1) + double(z) * decltype(got)(x2);
        for (int i = 0; i < got.length(); ++i)
          EXPECT_NEAR(got[i], want[i], 2e-5) << what << " of vertex " << v << " (triangle " << t << ")";
      };
      expectNear(glm::dvec3(refined.normals[v]), source.normals[s[0]], source.normals[s[1]], source.normals[s[2]],
                 "normal");
      expectNear(glm::dvec4(refined.tangents[v]), source.tangents[s[0]], source.tangents[s[1]], source.tangents[s[2]],
                 "tangent");
      expectNear(glm::dvec2(refined.uv0[v]), source.uv0[s[0]], source.uv0[s[1]], source.uv0[s[2]], "uv");
      expectNear(glm::dvec4(refined.colors[v]), source.colors[s[0]], source.colors[s[1]], source.colors[s[2]],
                 "colour");
      ++checked;
    }
  }
  EXPECT_EQ(checked, 3 * refined.triangleCount());
}

// All the properties at once: watertight as the source, same area (per source triangle too),
// interpolated attributes, every edge within the limit, winding kept.
void expectRefinement(const Mesh& source, float maxEdge) {
  std::vector<uint32_t> sourceTriangle;
  auto refined = refineMesh(source, maxEdge, 1u << 24, &sourceTriangle);
  ASSERT_TRUE(refined) << refined.error().message;
  const Mesh& out = *refined;
  EXPECT_GT(out.triangleCount(), source.triangleCount());
  EXPECT_EQ(out.material, source.material);
  EXPECT_EQ(out.name, source.name);

  Boundary before = boundaryOf(source), after = boundaryOf(out);
  EXPECT_NEAR(after.length, before.length, 1e-5 * std::max(1.0, before.length));
  if (before.edges == 0) {
    EXPECT_EQ(after.edges, 0u);
  }

  EXPECT_NEAR(area(out), area(source), 1e-5 * area(source));
  std::vector<double> pieces(source.triangleCount(), 0.0);
  for (size_t t = 0; t < out.triangleCount(); ++t) pieces[sourceTriangle[t]] += triangleArea(out, t);
  for (size_t t = 0; t < source.triangleCount(); ++t)
    EXPECT_NEAR(pieces[t], triangleArea(source, t), 1e-5 * std::max(1.0, triangleArea(source, t))) << t;

  EXPECT_LE(longestEdge(out), double(maxEdge) * (1.0 + 1e-6));
  for (size_t t = 0; t < out.triangleCount(); ++t) { // the pieces face as their source triangle does
    const uint32_t* s = &source.indices[3 * size_t(sourceTriangle[t])];
    glm::dvec3 n = glm::cross(glm::dvec3(source.positions[s[1]] - source.positions[s[0]]),
                              glm::dvec3(source.positions[s[2]] - source.positions[s[0]]));
    glm::dvec3 m = glm::cross(glm::dvec3(out.positions[out.indices[3 * t + 1]] - out.positions[out.indices[3 * t]]),
                              glm::dvec3(out.positions[out.indices[3 * t + 2]] - out.positions[out.indices[3 * t]]));
    EXPECT_GT(glm::dot(n, m), 0.0) << "triangle " << t;
  }
  if (!source.uv0.empty()) expectInterpolated(source, out, sourceTriangle);
}

TEST(Tessellate, ClosedMeshStaysClosed) {
  Mesh mesh = closedPolyhedron(3);
  ASSERT_EQ(boundaryOf(mesh).edges, 0u);
  expectRefinement(mesh, 0.8f);
}

TEST(Tessellate, SeamsOnEveryEdgeStayClosed) {
  // Every edge is held by two triangles with different vertex indices and attributes, read in
  // opposite directions: the split points must still be the same bits on both sides.
  Mesh mesh = unwelded(closedPolyhedron(5), 6);
  ASSERT_EQ(boundaryOf(mesh).edges, 0u);
  expectRefinement(mesh, 0.6f);
}

TEST(Tessellate, CubeFacesSplitEachEdgeByItsLength) {
  Mesh cube = test::makeCube(1.0f);
  for (glm::vec3& p : cube.positions) p *= glm::vec3(5.0f, 1.0f, 2.5f); // faces of different sizes
  randomAttributes(cube, 9);
  expectRefinement(cube, 0.5f);
  // An edge of length l is cut into ceil(l / L) equal pieces whichever triangle holds it: count the
  // output vertices on three of the cube's edges (each held by two faces with their own vertices).
  auto refined = refineMesh(cube, 0.5f, 1u << 20);
  ASSERT_TRUE(refined);
  std::vector<uint32_t> id = weldedIds(*refined);
  std::map<uint32_t, glm::vec3> points;
  for (size_t v = 0; v < refined->positions.size(); ++v) points[id[v]] = refined->positions[v];
  const glm::vec3 half(5.0f, 1.0f, 2.5f);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<float> onEdge; // points on the edge along `axis` at the other two coordinates' maxima
    for (const auto& [key, p] : points) {
      bool on = true;
      for (int other = 0; other < 3; ++other)
        if (other != axis && p[other] != half[other]) on = false;
      if (on) onEdge.push_back(p[axis]);
    }
    double length = 2.0 * half[axis];
    size_t pieces = size_t(std::ceil(length / 0.5));
    ASSERT_EQ(onEdge.size(), pieces + 1) << "axis " << axis;
    std::sort(onEdge.begin(), onEdge.end());
    for (size_t i = 1; i < onEdge.size(); ++i)
      EXPECT_NEAR(onEdge[i] - onEdge[i - 1], length / double(pieces), 1e-5) << "axis " << axis;
  }
}

TEST(Tessellate, OpenGridKeepsItsBorderAndPairsIntoPatches) {
  // A 3 x 2 grid of large quads: its border is kept (same length, no T-junction inside), and the
  // refined mesh still groups into patches (its pieces pair across their shared edges).
  Mesh grid;
  grid.name = "grid";
  for (int j = 0; j <= 2; ++j)
    for (int i = 0; i <= 3; ++i) grid.positions.push_back({float(i) * 8.0f, float(j) * 8.0f, 0.0f});
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) {
      uint32_t a = uint32_t(j * 4 + i), b = a + 1, c = a + 4, d = a + 5;
      grid.indices.insert(grid.indices.end(), {a, b, d, a, d, c});
    }
  randomAttributes(grid, 11);
  expectRefinement(grid, 1.0f);
  auto refined = refineMesh(grid, 1.0f, 1u << 20);
  ASSERT_TRUE(refined);
  MeshPatches patches = buildMeshPatches(*refined);
  size_t grouped = 0;
  for (const Patch& p : patches.patches) grouped += p.triangleCount >= 2 ? p.triangleCount : 0;
  EXPECT_GE(double(grouped) / double(refined->triangleCount()), 0.95);
}

TEST(Tessellate, SmallTrianglesAreLeftAlone) {
  Mesh mesh = closedPolyhedron(4);
  std::vector<uint32_t> sourceTriangle;
  auto refined = refineMesh(mesh, 100.0f, 1u << 20, &sourceTriangle);
  ASSERT_TRUE(refined);
  EXPECT_EQ(refined->indices, mesh.indices);
  EXPECT_EQ(refined->positions, mesh.positions);
  for (uint32_t t = 0; t < sourceTriangle.size(); ++t) EXPECT_EQ(sourceTriangle[t], t);
}

TEST(Tessellate, SceneInstancesScaleTheLimitAndKeepMaterials) {
  Scene scene =
      test::makeScene({test::makeQuad(10.0f, 0.0f, 0), test::makeCube(3.0f, 1)},
                      {test::solidMaterial({1, 0, 0, 1}), test::solidMaterial({0, 1, 0, 0.5f}, AlphaMode::Blend)});
  scene.instances[1].transform = glm::scale(glm::translate(glm::mat4(1.0f), {30, 0, 0}), glm::vec3(2.0f));
  scene.instances.push_back({1, glm::translate(glm::mat4(1.0f), {-30, 0, 0})});
  TessellationConfig config;
  config.maxPatchEdge = 1.5f;
  auto stats = tessellateScene(scene, config);
  ASSERT_TRUE(stats) << stats.error().message;
  EXPECT_EQ(stats->maxPatchEdge, 1.5f);
  EXPECT_EQ(stats->trianglesBefore, 2u + 12u + 12u);
  EXPECT_EQ(stats->trianglesAfter, scene.instancedTriangleCount());
  EXPECT_EQ(scene.meshes[0].material, 0u);
  EXPECT_EQ(scene.meshes[1].material, 1u);
  EXPECT_EQ(scene.materials[1].alphaMode, AlphaMode::Blend);
  // World edges within the limit on every instance (the scaled cube was refined for its scale).
  for (const Instance& instance : scene.instances) {
    const Mesh& mesh = scene.meshes[instance.mesh];
    for (size_t t = 0; t < mesh.triangleCount(); ++t)
      for (int k = 0; k < 3; ++k) {
        glm::vec3 p = instance.transform * glm::vec4(mesh.positions[mesh.indices[3 * t + k]], 1.0f);
        glm::vec3 q = instance.transform * glm::vec4(mesh.positions[mesh.indices[3 * t + (k + 1) % 3]], 1.0f);
        EXPECT_LE(glm::length(q - p), 1.5f * (1.0f + 1e-5f));
      }
  }
}

TEST(Tessellate, DefaultLimitFollowsTheSceneDiagonal) {
  Scene scene = test::makeScene({test::makeCube(2.0f)}, {});
  TessellationConfig config;
  EXPECT_FLOAT_EQ(patchEdgeLength(scene, config), std::sqrt(48.0f) / kPatchEdgeDivisions);
  config.maxPatchEdge = 0.25f;
  EXPECT_EQ(patchEdgeLength(scene, config), 0.25f);
  config.maxPatchEdge = std::numeric_limits<float>::infinity(); // off
  auto stats = tessellateScene(scene, config);
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->trianglesAfter, 12u);
  EXPECT_EQ(scene.meshes[0].triangleCount(), 12u);
}

TEST(Tessellate, LimitsAndBadConfigurationsAreRefused) {
  Scene scene = test::makeScene({test::makeQuad(100.0f, 0.0f)}, {});
  TessellationConfig config;
  config.maxPatchEdge = 0.01f; // about 10^9 triangles
  config.maxTriangles = 100000;
  auto over = tessellateScene(scene, config);
  ASSERT_FALSE(over);
  EXPECT_NE(over.error().message.find("100000"), std::string::npos) << over.error().message;
  EXPECT_EQ(over.error().message.find('\n'), std::string::npos);
  auto mesh = refineMesh(scene.meshes[0], 0.01f, 1000);
  ASSERT_FALSE(mesh);
  EXPECT_NE(mesh.error().message.find("quad"), std::string::npos) << mesh.error().message;

  for (float bad : {-1.0f, std::nanf("")}) {
    config = {};
    config.maxPatchEdge = bad;
    EXPECT_FALSE(tessellateScene(scene, config)) << bad;
  }
  config = {};
  config.maxTriangles = 0;
  EXPECT_FALSE(tessellateScene(scene, config));
  config = {};
  config.maxTriangles = 1; // the source already has more
  EXPECT_FALSE(tessellateScene(scene, config));

  Mesh broken = test::makeQuad(10.0f, 0.0f);
  broken.positions[2].x = std::numeric_limits<float>::infinity();
  auto refused = refineMesh(broken, 1.0f, 1u << 20);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("non-finite"), std::string::npos) << refused.error().message;
}

TEST(Tessellate, SponzaStaysWatertightWithInterpolatedAttributes) {
  MIRAGE_REQUIRE_DATA(path, "dabrovic-sponza/gltf/sponza.gltf");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene) << scene.error().message;
  const float maxEdge = 0.5f;
  size_t before = 0, after = 0;
  for (const Mesh& mesh : scene->meshes) {
    std::vector<uint32_t> sourceTriangle;
    auto refined = refineMesh(mesh, maxEdge, 1u << 24, &sourceTriangle);
    ASSERT_TRUE(refined) << refined.error().message;
    Boundary b0 = boundaryOf(mesh), b1 = boundaryOf(*refined);
    EXPECT_NEAR(b1.length, b0.length, 1e-5 * std::max(1.0, b0.length)) << mesh.name;
    EXPECT_NEAR(area(*refined), area(mesh), 1e-5 * std::max(1.0, area(mesh))) << mesh.name;
    EXPECT_LE(longestEdge(*refined), double(maxEdge) * (1.0 + 1e-6)) << mesh.name;
    before += mesh.triangleCount(), after += refined->triangleCount();
  }
  std::printf("Sponza: %zu triangles, %zu with edges <= %.2f\n", before, after, double(maxEdge));
}

} // namespace
} // namespace mirage::stream
