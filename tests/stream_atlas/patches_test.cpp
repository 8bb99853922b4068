// Patch building (every triangle once, layout and winding as shaderio/atlas.h, pairing rate and
// shape), the global patch table and level selection on analytic cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "mirage/io/import.h"
#include "mirage/stream/patches.h"
#include "test_scenes.h"
#include "test_support.h"

namespace mirage::stream {
namespace {

// n x n quads in the xy plane, CCW seen from +z; `alternate` flips every other quad's diagonal.
Mesh gridMesh(uint32_t n, bool alternate = false, float jitter = 0.0f) {
  Mesh mesh;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> offset(-jitter, jitter);
  for (uint32_t j = 0; j <= n; ++j) {
    for (uint32_t i = 0; i <= n; ++i) mesh.positions.push_back({float(i) + offset(rng), float(j) + offset(rng), 0.0f});
  }
  auto v = [n](uint32_t i, uint32_t j) { return j * (n + 1) + i; };
  for (uint32_t j = 0; j < n; ++j) {
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t a = v(i, j), b = v(i + 1, j), c = v(i, j + 1), d = v(i + 1, j + 1);
      if (alternate && (i + j) % 2) {
        mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
      } else {
        mesh.indices.insert(mesh.indices.end(), {a, b, c, c, b, d});
      }
    }
  }
  mesh.normals.assign(mesh.positions.size(), glm::vec3(0, 0, 1));
  return mesh;
}

bool sameWinding(const uint32_t x[3], const uint32_t y[3]) {
  for (uint32_t r = 0; r < 3; ++r) {
    if (x[0] == y[r] && x[1] == y[(r + 1) % 3] && x[2] == y[(r + 2) % 3]) return true;
  }
  return false;
}

// Every triangle in exactly one patch, patchOfTriangle agreeing, and each patch triangle's slots
// (atlasTriangleVertex) naming its source triangle's vertices in the source winding.
void expectValidPatches(const Mesh& mesh, const MeshPatches& patches) {
  ASSERT_EQ(patches.patchOfTriangle.size(), mesh.triangleCount());
  std::vector<uint32_t> seen(mesh.triangleCount(), 0);
  for (uint32_t p = 0; p < patches.patches.size(); ++p) {
    const Patch& patch = patches.patches[p];
    ASSERT_GE(patch.triangleCount, 1u);
    ASSERT_LE(patch.triangleCount, 3u);
    for (uint32_t t = 0; t < patch.triangleCount; ++t) {
      uint32_t source = patch.triangles[t];
      ASSERT_LT(source, mesh.triangleCount());
      seen[source]++;
      EXPECT_EQ(patches.patchOfTriangle[source], p);
      uint32_t slots[3], original[3];
      for (uint32_t k = 0; k < 3; ++k) {
        slots[k] = patch.vertices[shaderio::atlasTriangleVertex(t, k)];
        original[k] = mesh.indices[3 * source + k];
      }
      EXPECT_TRUE(sameWinding(slots, original)) << "patch " << p << " triangle " << t << " (source " << source << ")";
    }
  }
  for (uint32_t t = 0; t < seen.size(); ++t) EXPECT_EQ(seen[t], 1u) << "triangle " << t;
}

double groupedFraction(const MeshPatches& patches) {
  size_t grouped = 0, total = 0;
  for (const Patch& patch : patches.patches) {
    total += patch.triangleCount;
    if (patch.triangleCount >= 2) grouped += patch.triangleCount;
  }
  return total ? double(grouped) / double(total) : 0.0;
}

TEST(Patches, RegularGridPairsIntoSquares) {
  Mesh mesh = gridMesh(16);
  MeshPatches patches = buildMeshPatches(mesh);
  expectValidPatches(mesh, patches);
  EXPECT_GE(groupedFraction(patches), 0.8);
  // Best pairs first: every pair is one grid quad, an undistorted square block.
  for (const Patch& patch : patches.patches) {
    glm::vec3 positions[5];
    patchPositions(mesh, patch, positions);
    EXPECT_NEAR(patchStretch(positions, patch.triangleCount), 1.0f, 1e-4f);
  }
}

TEST(Patches, AlternatingAndJitteredGrids) {
  for (Mesh mesh : {gridMesh(15, true), gridMesh(15, false, 0.2f), gridMesh(7, true, 0.3f)}) {
    MeshPatches patches = buildMeshPatches(mesh);
    expectValidPatches(mesh, patches);
    EXPECT_GE(groupedFraction(patches), 0.8);
  }
}

TEST(Patches, OddTriangleLeftOverJoinsAPairAsWideBlock) {
  // Three triangles in a strip: a quad (pair) and one more triangle across the quad's right edge.
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 0, 0}};
  mesh.indices = {0, 1, 2, 2, 1, 3, 1, 4, 3};
  MeshPatches patches = buildMeshPatches(mesh);
  expectValidPatches(mesh, patches);
  ASSERT_EQ(patches.patches.size(), 1u);
  EXPECT_EQ(patches.patches[0].triangleCount, 3u);
  glm::vec3 positions[5];
  patchPositions(mesh, patches.patches[0], positions);
  EXPECT_NEAR(patchStretch(positions, 3), 1.0f, 1e-4f);
}

TEST(Patches, InconsistentWindingStaysSingle) {
  // Both triangles hold the edge 1 -> 2: pairing them would flip one's winding.
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  mesh.indices = {0, 1, 2, 3, 1, 2};
  MeshPatches patches = buildMeshPatches(mesh);
  expectValidPatches(mesh, patches);
  EXPECT_EQ(patches.patches.size(), 2u);
}

TEST(Patches, SphereMostlyGrouped) {
  Mesh sphere = test::makeSphere(1.0f, 24, 48);
  MeshPatches patches = buildMeshPatches(sphere);
  expectValidPatches(sphere, patches);
  EXPECT_GE(groupedFraction(patches), 0.8);
}

TEST(Patches, BunnyMostlyGrouped) {
  MIRAGE_REQUIRE_DATA(path, "stanford-bunny/bun_zipper.ply");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  for (const Mesh& mesh : scene->meshes) {
    MeshPatches patches = buildMeshPatches(mesh);
    expectValidPatches(mesh, patches);
    double fraction = groupedFraction(patches);
    std::printf("bunny: %zu triangles, %zu patches, %.3f in 2-3 triangle patches\n", mesh.triangleCount(),
                patches.patches.size(), fraction);
    EXPECT_GE(fraction, 0.8);
  }
}

TEST(Patches, TableNumbersInstancesGlobally) {
  Scene scene = test::makeScene({gridMesh(3), test::makeCube()}, {test::solidMaterial(glm::vec4(1))});
  scene.instances.push_back({0, glm::translate(glm::mat4(1.0f), glm::vec3(5, 0, 0))});
  scene.instances.push_back({1, glm::mat4(1.0f)});
  PatchTable table = buildPatchTable(scene);
  ASSERT_EQ(table.instancePatchOffset.size(), scene.instances.size() + 1);
  uint32_t expected = 0;
  for (const Instance& instance : scene.instances) expected += uint32_t(table.meshes[instance.mesh].patches.size());
  EXPECT_EQ(table.patchCount(), expected);
  EXPECT_EQ(table.triangleCount(), scene.instancedTriangleCount());

  for (uint32_t id = 0; id < table.patchCount(); ++id) {
    PatchRef ref = table.patchRef(id);
    ASSERT_LT(ref.instance, scene.instances.size());
    EXPECT_EQ(table.globalPatch(ref), id);
    EXPECT_LT(ref.meshPatch, table.meshes[table.instanceMesh[ref.instance]].patches.size());
  }
  // Instance-major triangle ids land in the patch holding that triangle of that instance.
  for (uint32_t instance = 0; instance < scene.instances.size(); ++instance) {
    const Mesh& mesh = scene.meshes[scene.instances[instance].mesh];
    for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
      uint32_t id = table.patchOfTriangle(table.instanceTriangleOffset[instance] + t);
      PatchRef ref = table.patchRef(id);
      EXPECT_EQ(ref.instance, instance);
      const Patch& patch = table.patch(ref);
      EXPECT_TRUE(std::find(patch.triangles, patch.triangles + patch.triangleCount, t) !=
                  patch.triangles + patch.triangleCount);
    }
  }
  // World positions follow the instance transform.
  glm::vec3 local[5], world[5];
  uint32_t second = table.instancePatchOffset[2]; // the translated grid
  patchPositions(scene.meshes[0], table.patch(table.patchRef(second)), local);
  patchWorldPositions(scene, table, second, world);
  EXPECT_EQ(world[0], local[0] + glm::vec3(5, 0, 0));
}

// A unit square pair of side `side` centred at the origin in the z = 0 plane.
std::vector<glm::vec3> squarePatch(float side) {
  float h = side * 0.5f;
  return {{-h, -h, 0}, {h, -h, 0}, {-h, h, 0}, {h, h, 0}, {-h, -h, 0}};
}

TEST(Patches, LevelFromProjectedSize) {
  // Identity view-projection: NDC = world xy, so a side s covers s * 500 pixels of a 1000^2 viewport.
  glm::mat4 identity(1.0f);
  glm::uvec2 viewport(1000, 1000);
  EXPECT_EQ(patchBlockLog2(squarePatch(0.2f), 2, identity, viewport), 7u);         // 100 px: 101 texels -> 128
  EXPECT_EQ(patchBlockLog2(squarePatch(0.05f), 2, identity, viewport), 5u);        // 25 px: 26 texels -> 32
  EXPECT_EQ(patchBlockLog2(squarePatch(0.05f), 2, identity, viewport, 1.0f), 6u);  // bias +1: 51 -> 64
  EXPECT_EQ(patchBlockLog2(squarePatch(0.05f), 2, identity, viewport, -2.0f), 3u); // bias -2: 7.25 -> 8
  EXPECT_EQ(patchBlockLog2(squarePatch(0.001f), 2, identity, viewport), uint32_t(MIRAGE_ATLAS_MIN_BLOCK_LOG2));
  EXPECT_EQ(patchBlockLog2(squarePatch(4.0f), 2, identity, viewport), uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2));
  EXPECT_EQ(patchBlockLog2(squarePatch(4.0f), 3, identity, viewport), uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2 - 1));

  // Perspective, 90 degrees: a unit square facing the camera at distance z spans 512 / z pixels of 1024.
  glm::mat4 viewProj = glm::perspective(glm::radians(90.0f), 1.0f, 0.1f, 100.0f);
  for (float z : {3.0f, 10.0f, 20.0f, 40.0f, 90.0f}) {
    std::vector<glm::vec3> square = squarePatch(1.0f);
    for (glm::vec3& p : square) p.z = -z;
    uint32_t expected = uint32_t(std::ceil(std::log2(512.0f / z + 1.0f)));
    expected = std::clamp(expected, uint32_t(MIRAGE_ATLAS_MIN_BLOCK_LOG2), uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2));
    EXPECT_EQ(patchBlockLog2(square, 2, viewProj, {1024, 1024}), expected) << "z " << z;
  }
  // A vertex behind the eye: as close as it gets.
  std::vector<glm::vec3> crossing = squarePatch(1.0f);
  crossing[0].z = 1.0f;
  EXPECT_EQ(patchBlockLog2(crossing, 2, viewProj, {1024, 1024}), uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2));
}

TEST(Patches, LevelStepsAreLengthThenLevel) {
  glm::mat4 identity(1.0f);
  glm::uvec2 viewport(1000, 1000);
  EXPECT_FLOAT_EQ(patchProjectedLength(squarePatch(0.2f), 2, identity, viewport), 100.0f);
  EXPECT_EQ(blockLog2ForLength(100.0f, 2, 0.0f), 7u);
  EXPECT_EQ(blockLog2ForLength(25.0f, 2, 1.0f), 6u);
  EXPECT_EQ(blockLog2ForLength(std::numeric_limits<float>::infinity(), 3, -5.0f),
            uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2 - 1));
  EXPECT_EQ(blockTexels(7, 2), 16384u);
  EXPECT_EQ(blockTexels(6, 3), 8192u);
}

uint64_t texelsAt(std::span<const PatchExtent> patches, float bias) {
  uint64_t total = 0;
  for (const PatchExtent& p : patches)
    total += blockTexels(blockLog2ForLength(p.length, p.triangleCount, bias), p.triangleCount);
  return total;
}

TEST(Patches, FittedBiasKeepsTheBlocksWithinTheBudget) {
  // 100 pairs of 100 px want 128-texel blocks (1.6 M texels). A budget of 64-texel blocks needs
  // 100 * 2^b + 1 <= 64: b <= log2(0.63) = -0.67, so the first quarter level that fits is -0.75.
  std::vector<PatchExtent> same(100, PatchExtent{100.0f, 2});
  EXPECT_EQ(fitLevelBias(same, 0.0f, 100 * 16384), 0.0f); // fits: unchanged
  EXPECT_EQ(fitLevelBias(same, 0.0f, 100 * 4096), -0.75f);
  EXPECT_EQ(fitLevelBias(same, 1.0f, 100 * 4096), -0.75f); // the same bias from a higher start

  // Mixed sizes, shapes and a patch through the eye plane: the result fits and a quarter level more
  // does not.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> length(0.5f, 400.0f);
  std::vector<PatchExtent> mixed;
  for (int i = 0; i < 500; ++i) mixed.push_back({length(rng), uint32_t(1 + i % 3)});
  mixed.push_back({std::numeric_limits<float>::infinity(), 2});
  for (uint64_t budget : {uint64_t(3000000), uint64_t(400000), uint64_t(60000)}) {
    float bias = fitLevelBias(mixed, 1.0f, budget);
    EXPECT_LE(texelsAt(mixed, bias), budget) << budget;
    EXPECT_GT(texelsAt(mixed, bias + 0.25f), budget) << budget;
  }
  // Nothing fits: every finite patch at the smallest level, the one through the eye plane at the largest.
  float floor = fitLevelBias(mixed, 1.0f, 0);
  for (const PatchExtent& p : mixed)
    EXPECT_EQ(blockLog2ForLength(p.length, p.triangleCount, floor),
              std::isfinite(p.length) ? uint32_t(MIRAGE_ATLAS_MIN_BLOCK_LOG2) : uint32_t(MIRAGE_ATLAS_MAX_BLOCK_LOG2));
}

} // namespace
} // namespace mirage::stream
