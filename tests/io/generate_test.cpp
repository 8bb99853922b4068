#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "mirage/io/generate.h"

using namespace mirage;

namespace {

template <class T> bool sameBytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool identical(const Scene& a, const Scene& b) {
  if (a.meshes.size() != b.meshes.size() || a.instances.size() != b.instances.size()) return false;
  for (size_t i = 0; i < a.meshes.size(); ++i) {
    const Mesh &x = a.meshes[i], &y = b.meshes[i];
    if (!sameBytes(x.positions, y.positions) || !sameBytes(x.normals, y.normals) || !sameBytes(x.uv0, y.uv0) ||
        !sameBytes(x.colors, y.colors) || !sameBytes(x.indices, y.indices) || x.material != y.material)
      return false;
  }
  for (size_t i = 0; i < a.instances.size(); ++i)
    if (a.instances[i].mesh != b.instances[i].mesh ||
        std::memcmp(&a.instances[i].transform, &b.instances[i].transform, sizeof(glm::mat4)) != 0)
      return false;
  return true;
}

// Undirected edge -> (uses, net direction) after welding vertices with bit-identical positions.
struct EdgeStats {
  std::map<std::pair<uint32_t, uint32_t>, std::pair<int, int>> edges;
  size_t vertices = 0;
};
EdgeStats edgeStats(const Mesh& m) {
  std::map<std::tuple<float, float, float>, uint32_t> weld;
  std::vector<uint32_t> remap(m.positions.size());
  for (size_t i = 0; i < m.positions.size(); ++i) {
    auto key = std::make_tuple(m.positions[i].x, m.positions[i].y, m.positions[i].z);
    remap[i] = weld.emplace(key, uint32_t(weld.size())).first->second;
  }
  EdgeStats s;
  s.vertices = weld.size();
  for (size_t t = 0; t < m.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = remap[m.indices[t + k]], b = remap[m.indices[t + (k + 1) % 3]];
      auto& e = s.edges[std::minmax(a, b)];
      e.first += 1;
      e.second += a < b ? 1 : -1;
    }
  return s;
}

void expectSane(const Scene& s) {
  ASSERT_FALSE(s.materials.empty());
  ASSERT_FALSE(s.instances.empty());
  for (const Material& mat : s.materials)
    if (mat.baseColorTexture >= 0) {
      EXPECT_LT(size_t(mat.baseColorTexture), s.textures.size());
    }
  for (const Instance& inst : s.instances) {
    ASSERT_LT(inst.mesh, s.meshes.size());
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) EXPECT_TRUE(std::isfinite(inst.transform[c][r]));
  }
  for (const Mesh& m : s.meshes) {
    EXPECT_LT(m.material, s.materials.size());
    ASSERT_EQ(m.normals.size(), m.positions.size()) << m.name;
    EXPECT_TRUE(m.uv0.empty() || m.uv0.size() == m.positions.size());
    EXPECT_TRUE(m.colors.empty() || m.colors.size() == m.positions.size());
    EXPECT_EQ(m.indices.size() % 3, 0u);
    EXPECT_FALSE(m.bounds.empty()) << m.name;
    size_t bad = 0;
    for (size_t i = 0; i < m.positions.size(); ++i) {
      const glm::vec3 &p = m.positions[i], &n = m.normals[i];
      bool finite = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
      bool unit = std::abs(glm::length(n) - 1.0f) < 1e-4f;
      bool inside = glm::all(glm::lessThanEqual(m.bounds.min, p)) && glm::all(glm::lessThanEqual(p, m.bounds.max));
      bad += !(finite && unit && inside);
    }
    EXPECT_EQ(bad, 0u) << m.name;
    for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size());
  }
}

double signedVolume(const Mesh& m) {
  double v = 0;
  for (size_t t = 0; t < m.indices.size(); t += 3) {
    glm::dvec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
    v += glm::dot(a, glm::cross(b, c)) / 6.0;
  }
  return v;
}

} // namespace

TEST(Generate, DeterministicForSeed) {
  io::BlobOptions blob;
  blob.subdivisions = 4;
  io::TerrainOptions terrain;
  terrain.resolution = 97;
  io::CityOptions city;
  city.blocks = 2;
  EXPECT_TRUE(identical(io::generateBlob(blob), io::generateBlob(blob)));
  EXPECT_TRUE(identical(io::generateTerrain(terrain), io::generateTerrain(terrain)));
  EXPECT_TRUE(identical(io::generateCity(city), io::generateCity(city)));
  Scene b1 = io::generateBlob(blob), t1 = io::generateTerrain(terrain), c1 = io::generateCity(city);
  blob.seed = terrain.seed = city.seed = 2;
  EXPECT_FALSE(identical(b1, io::generateBlob(blob)));
  EXPECT_FALSE(identical(t1, io::generateTerrain(terrain)));
  EXPECT_FALSE(identical(c1, io::generateCity(city)));
}

TEST(Generate, BlobCountsFollowFormula) {
  for (uint32_t s = 0; s <= 6; ++s) {
    io::BlobOptions o;
    o.subdivisions = s;
    Scene scene = io::generateBlob(o);
    ASSERT_EQ(scene.meshes.size(), 1u);
    EXPECT_EQ(scene.meshes[0].triangleCount(), 20u << (2 * s)) << s;
    EXPECT_EQ(scene.meshes[0].vertexCount(), (10u << (2 * s)) + 2) << s;
    EXPECT_EQ(scene.instancedTriangleCount(), 20u << (2 * s));
    expectSane(scene);
  }
}

TEST(Generate, BlobIsClosedOrientedManifold) {
  for (uint32_t s : {0u, 1u, 2u, 4u}) {
    io::BlobOptions o;
    o.subdivisions = s;
    o.seed = 3 + s;
    const Scene scene = io::generateBlob(o);
    const Mesh& m = scene.meshes[0];
    EdgeStats st = edgeStats(m);
    EXPECT_EQ(st.vertices, m.vertexCount()) << "no duplicate positions";
    for (const auto& [edge, use] : st.edges) {
      ASSERT_EQ(use.first, 2) << "s=" << s << " edge " << edge.first << "-" << edge.second;
      ASSERT_EQ(use.second, 0) << "neighbouring triangles must have opposite edge directions";
    }
    // Euler characteristic of a sphere: V - E + F = 2.
    EXPECT_EQ(int64_t(st.vertices) - int64_t(st.edges.size()) + int64_t(m.triangleCount()), 2);
    EXPECT_GT(signedVolume(m), 0.0) << "faces point outward";
  }
}

TEST(Generate, TerrainIsOpenGridWithBorder) {
  io::TerrainOptions o;
  o.resolution = 33;
  Scene scene = io::generateTerrain(o);
  const Mesh& m = scene.meshes[0];
  EXPECT_EQ(m.vertexCount(), 33u * 33u);
  EXPECT_EQ(m.triangleCount(), 2u * 32u * 32u);
  expectSane(scene);
  EdgeStats st = edgeStats(m);
  size_t border = 0;
  for (const auto& [edge, use] : st.edges) {
    ASSERT_TRUE(use.first == 1 || use.first == 2);
    border += use.first == 1;
  }
  EXPECT_EQ(border, 4u * 32u);
  for (const glm::vec3& n : m.normals) EXPECT_GT(n.y, 0.0f);
  EXPECT_GT(m.bounds.extent().y, 1.0f); // not flat
  EXPECT_NEAR(m.bounds.extent().x, o.size, 1e-3f);
  io::TerrainOptions d;
  EXPECT_EQ(size_t(2) * (d.resolution - 1) * (d.resolution - 1), 2093058u); // default is ~2M triangles
}

TEST(Generate, CityInstancesSharedMeshes) {
  io::CityOptions o;
  o.blocks = 3;
  Scene scene = io::generateCity(o);
  expectSane(scene);
  const size_t buildings = 9 * o.lotsPerBlockSide * o.lotsPerBlockSide;
  EXPECT_EQ(scene.instances.size(), 1 + 9 + buildings * 3);
  std::map<uint32_t, int> uses;
  for (const Instance& i : scene.instances) uses[i.mesh]++;
  int shared = 0;
  for (auto [mesh, n] : uses) shared += n > 1;
  EXPECT_GE(shared, 2);
  EXPECT_LT(scene.meshes.size(), scene.instances.size());
  bool blend = false;
  for (const Material& m : scene.materials) blend |= m.alphaMode == AlphaMode::Blend;
  EXPECT_TRUE(blend);
  ASSERT_EQ(scene.textures.size(), 1u);
  EXPECT_EQ(scene.textures[0].rgba8.size(), 64u * 64u * 4u);
  EXPECT_GT(scene.instancedTriangleCount(), 50000u);
  // Buildings stand inside the ground plane's extent.
  Bounds world = scene.worldBounds(), ground = scene.meshes[0].bounds;
  EXPECT_GE(world.min.x, ground.min.x - 1e-3f);
  EXPECT_LE(world.max.z, ground.max.z + 1e-3f);
  EXPECT_GT(world.extent().y, 9.0f);
  // Interiors are optional and cut the triangle count.
  o.interiors = false;
  EXPECT_LT(io::generateCity(o).meshTriangleCount(), scene.meshTriangleCount());
}

// Street cells lie on the streets: inside the ground, above the sidewalk slabs and clear of every
// building (no instance's world box reaches into a cell), 2 (blocks + 1) streets of N cells each,
// half of them running along x and half along z.
TEST(Generate, CityStreetCellsLieOnTheStreets) {
  for (uint32_t blocks : {1u, 3u})
    for (uint32_t lots : {1u, 2u}) {
      io::CityOptions o;
      o.blocks = blocks;
      o.lotsPerBlockSide = lots;
      Scene scene = io::generateCity(o);
      const uint32_t perStreet = 7;
      std::vector<Bounds> cells = io::cityStreetCells(o, perStreet);
      ASSERT_EQ(cells.size(), size_t(2) * (blocks + 1) * perStreet);
      EXPECT_TRUE(io::cityStreetCells(o, 0).empty());
      Bounds ground = scene.meshes[0].bounds;
      std::set<float> alongX, alongZ; // the streets' fixed coordinate
      for (size_t i = 0; i < cells.size(); ++i) {
        const Bounds& c = cells[i];
        EXPECT_GE(c.min.x, ground.min.x);
        EXPECT_LE(c.max.z, ground.max.z);
        EXPECT_NEAR(c.extent().y, 2.0f, 1e-5f);
        (i < cells.size() / 2 ? alongX : alongZ).insert(i < cells.size() / 2 ? c.center().z : c.center().x);
        for (const Instance& inst : scene.instances) {
          Bounds b = transformBounds(scene.meshes[inst.mesh].bounds, inst.transform);
          bool overlaps = glm::all(glm::lessThan(b.min, c.max)) && glm::all(glm::lessThan(c.min, b.max));
          ASSERT_FALSE(overlaps) << "cell " << i << " meets mesh " << scene.meshes[inst.mesh].name << " (blocks "
                                 << blocks << ", lots " << lots << ")";
        }
      }
      EXPECT_EQ(alongX.size(), blocks + 1);
      EXPECT_EQ(alongZ.size(), blocks + 1);
    }
}

TEST(Generate, CityScalesWithBlocks) {
  io::CityOptions small, large;
  small.blocks = 1;
  large.blocks = 4;
  size_t a = io::generateCity(small).instancedTriangleCount(), b = io::generateCity(large).instancedTriangleCount();
  EXPECT_GT(a, 1000u);
  EXPECT_GT(b, 8 * a); // 16x the lots, variants drawn at random
}

TEST(Generate, SceneByName) {
  Result<Scene> blob = io::generateScene("blob", 5, 2);
  ASSERT_TRUE(blob.ok());
  EXPECT_EQ(blob->meshTriangleCount(), 320u);
  EXPECT_EQ(blob->source, "generated:blob");
  ASSERT_TRUE(io::generateScene("terrain", 1, 9).ok());
  EXPECT_EQ(io::generateScene("terrain", 1, 9)->meshTriangleCount(), 128u);
  ASSERT_TRUE(io::generateScene("city", 1, 1).ok());
  Result<Scene> bad = io::generateScene("castle", 1, 0);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("castle"), std::string::npos);
  EXPECT_FALSE(io::generateScene("blob", 1, 12).ok());
  EXPECT_FALSE(io::generateScene("terrain", 1, 1).ok());
  EXPECT_FALSE(io::generateScene("city", 1, 100000).ok());
}

// gen:many: each mesh made alone equals the same mesh of the whole scene (what a streaming bake
// relies on), the meshes are distinct variants of about the asked size, and the layout places one
// instance per mesh without geometry.
TEST(Generate, ManyMeshesAreMadeAloneAndDistinct) {
  io::ManyOptions o;
  o.count = 5;
  o.triangles = 2000; // n = 10: 2000 triangles exactly
  o.seed = 3;
  Scene whole = io::generateMany(o);
  Scene layout = io::generateManyLayout(o);
  ASSERT_EQ(whole.meshes.size(), 5u);
  ASSERT_EQ(layout.instances.size(), 5u);
  for (uint32_t i = 0; i < o.count; ++i) {
    EXPECT_TRUE(layout.meshes[i].positions.empty());
    EXPECT_EQ(layout.meshes[i].name, whole.meshes[i].name);
    EXPECT_EQ(layout.instances[i].mesh, i);
    Mesh alone = io::generateManyMesh(o, i);
    EXPECT_EQ(alone.positions, whole.meshes[i].positions);
    EXPECT_EQ(alone.indices, whole.meshes[i].indices);
    EXPECT_EQ(alone.triangleCount(), 2000u);
    if (i > 0) {
      EXPECT_NE(alone.positions, whole.meshes[0].positions) << "mesh " << i << " repeats mesh 0";
    }
  }
  auto parsed = io::parseManySize("512x2000000", 9);
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed->count, 512u);
  EXPECT_EQ(parsed->triangles, 2000000u);
  EXPECT_EQ(parsed->seed, 9u);
  EXPECT_FALSE(io::parseManySize("0x5", 1).ok());
  EXPECT_FALSE(io::parseManySize("12y", 1).ok());
  // Any segment count gives the closed 20 n² icosphere the blob is (n = 316: 1 997 120 triangles).
  io::BlobOptions b;
  b.segments = 7;
  EXPECT_EQ(io::generateBlob(b).meshes[0].triangleCount(), 20u * 49u);
}
