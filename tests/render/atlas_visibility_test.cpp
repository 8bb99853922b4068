// The atlas visibility stage (render/atlas_shading.h), both methods (compute raster, hardware
// passes), on hand-made scenes against a CPU ray cast: occlusion, MASK cut-outs, transparency in
// front of and behind a wall, two cameras, bad input; and the two methods against each other on a
// city. Validation must stay silent.
#include <algorithm>
#include <cmath>
#include <ostream>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/render/atlas_shading.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::GpuTest;

namespace {

uint32_t totalTriangles(const Scene& s) {
  uint32_t n = 0;
  for (const Instance& i : s.instances) n += uint32_t(s.meshes[i.mesh].triangleCount());
  return n;
}

// Two consecutive global triangles per patch (a quad or a cube face each).
std::vector<uint32_t> pairPatches(const Scene& s) {
  std::vector<uint32_t> map(totalTriangles(s));
  for (uint32_t t = 0; t < map.size(); ++t) map[t] = t / 2;
  return map;
}

Camera camera(glm::vec3 eye, glm::vec3 target = {0, 0, 0}) {
  Camera c;
  c.eye = eye;
  c.target = target;
  c.fovYDegrees = 45.0f;
  return c;
}

// The patches a ray cast through each pixel centre sees (per patch: its pixel count): the
// nearest opaque/MASK-kept hit, and BLEND hits in front of it; single-sided back faces are not hit.
// MASK materials here cut by their factor alone (no textures).
std::vector<uint32_t> rayCastPixels(const Scene& scene, const std::vector<uint32_t>& patchOf, const Camera& cam,
                                    uint32_t w, uint32_t h) {
  glm::mat4 inv = viewFrame(withClipPlanes(cam, scene.worldBounds()), w, h).invViewProj;
  struct Tri {
    glm::vec3 p[3];
    bool blend, doubleSided;
    uint32_t patch;
  };
  std::vector<Tri> tris;
  uint32_t id = 0;
  for (const Instance& inst : scene.instances) {
    const Mesh& m = scene.meshes[inst.mesh];
    const Material& mat = scene.materials[m.material];
    for (size_t t = 0; t < m.triangleCount(); ++t, ++id) {
      if (mat.alphaMode == AlphaMode::Mask && mat.baseColorFactor.a < mat.alphaCutoff) continue; // all cut away
      Tri tri{{}, mat.alphaMode == AlphaMode::Blend, mat.doubleSided, patchOf[id]};
      for (int k = 0; k < 3; ++k)
        tri.p[k] = glm::vec3(inst.transform * glm::vec4(m.positions[m.indices[t * 3 + k]], 1));
      tris.push_back(tri);
    }
  }
  std::vector<uint32_t> pixels(*std::max_element(patchOf.begin(), patchOf.end()) + 1, 0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      glm::vec2 ndc((x + 0.5f) / w * 2 - 1, (y + 0.5f) / h * 2 - 1);
      glm::vec4 nearP = inv * glm::vec4(ndc, 1, 1), farP = inv * glm::vec4(ndc, 0.5f, 1);
      glm::vec3 o = glm::vec3(nearP) / nearP.w, dir = glm::normalize(glm::vec3(farP) / farP.w - o);
      float best = 1e30f;
      int bestPatch = -1;
      std::vector<std::pair<float, uint32_t>> blendHits;
      for (const Tri& t : tris) {
        glm::vec3 e1 = t.p[1] - t.p[0], e2 = t.p[2] - t.p[0], n = glm::cross(e1, e2);
        if (!t.doubleSided && glm::dot(n, dir) >= 0) continue;
        glm::vec3 pv = glm::cross(dir, e2);
        float det = glm::dot(e1, pv);
        if (std::abs(det) < 1e-12f) continue;
        glm::vec3 tv = o - t.p[0];
        float u = glm::dot(tv, pv) / det;
        glm::vec3 qv = glm::cross(tv, e1);
        float v = glm::dot(dir, qv) / det, dist = glm::dot(e2, qv) / det;
        if (u < 0 || v < 0 || u + v > 1 || dist <= 0) continue;
        if (t.blend)
          blendHits.push_back({dist, t.patch});
        else if (dist < best)
          best = dist, bestPatch = int(t.patch);
      }
      if (bestPatch >= 0) pixels[bestPatch]++;
      for (auto [dist, patch] : blendHits)
        if (dist < best) pixels[patch]++;
    }
  return pixels;
}

std::set<uint32_t> visibleSet(const std::vector<uint32_t>& pixels) {
  std::set<uint32_t> s;
  for (uint32_t p = 0; p < pixels.size(); ++p)
    if (pixels[p]) s.insert(p);
  return s;
}

// The GPU set equals the ray cast's up to patches the ray cast sees in at most 2 pixels (edge
// pixels where rasterization and the ray test may round differently).
void expectMatchesRayCast(const std::vector<uint32_t>& gpu, const std::vector<uint32_t>& pixels) {
  std::set<uint32_t> got(gpu.begin(), gpu.end()), want = visibleSet(pixels);
  for (uint32_t p : want)
    if (pixels[p] > 2) {
      EXPECT_TRUE(got.count(p)) << "patch " << p << " (" << pixels[p] << " pixels) not visible";
    }
  size_t extra = 0;
  for (uint32_t p : got) extra += !want.count(p);
  EXPECT_LE(extra, 1u) << "patches visible on the GPU that no ray sees";
}

Mesh translated(Mesh m, glm::vec3 offset) {
  for (glm::vec3& p : m.positions) p += offset;
  m.bounds = Bounds{};
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

} // namespace

namespace mirage::render {
// The method's name in test names (ctest lists the parameter).
void PrintTo(AtlasVisibilityMethod method, std::ostream* os) { *os << nameOf(kAtlasVisibilityMethodNames, method); }
} // namespace mirage::render

class AtlasVisibility : public GpuTest, public ::testing::WithParamInterface<AtlasVisibilityMethod> {
protected:
  // The method under test; false (the test skips) where the device lacks the compute raster's atomics.
  bool method(AtlasShadingConfig& config) {
    config.visibility = GetParam();
    return GetParam() != AtlasVisibilityMethod::Compute ||
           (context().caps().int64BufferAtomics && context().caps().int64SharedAtomics);
  }
  Result<std::unique_ptr<AtlasShading>> create(const Scene& scene, std::vector<uint32_t> patchOf,
                                               AtlasShadingConfig config = {}) {
    if (!method(config)) return Error{"no compute raster on this device"};
    auto atlas = AtlasShading::create(context(), scene, std::move(patchOf), config);
    if (atlas.ok()) {
      EXPECT_EQ(atlas.value()->visibilityMethod(), GetParam());
    }
    return atlas;
  }
  void SetUp() override {
    GpuTest::SetUp();
    AtlasShadingConfig config;
    if (!method(config)) GTEST_SKIP() << "no 64-bit buffer and shared atomics: no compute visibility";
  }
};

INSTANTIATE_TEST_SUITE_P(Methods, AtlasVisibility,
                         ::testing::Values(AtlasVisibilityMethod::Compute, AtlasVisibilityMethod::Hardware),
                         [](const ::testing::TestParamInfo<AtlasVisibilityMethod>& p) {
                           return std::string(p.param == AtlasVisibilityMethod::Compute ? "Compute" : "Hardware");
                         });

TEST_P(AtlasVisibility, BoxBehindWallIsHiddenBoxBesideIsNot) {
  // Wall z = 0 (half size 1), a box behind it, a box beside it (its +Z and -X faces face the eye).
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f), translated(test::makeCube(0.5f), {0, 0, -2}),
                                 translated(test::makeCube(0.5f), {2.5f, 0, 0})},
                                {test::solidMaterial({0.8f, 0.8f, 0.8f, 1})});
  std::vector<uint32_t> patchOf = pairPatches(scene); // wall 0, hidden box 1..6, side box 7..12
  auto atlas = create(scene, patchOf);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  EXPECT_EQ(atlas.value()->patchCount(), 13u);
  Camera cam = camera({0, 0, 5});
  auto vis = atlas.value()->visibility({&cam, 1}, 96, 72);
  ASSERT_TRUE(vis.ok()) << vis.error().message;
  std::set<uint32_t> got(vis->begin(), vis->end());
  EXPECT_TRUE(got.count(0));
  for (uint32_t p = 1; p <= 6; ++p) EXPECT_FALSE(got.count(p)) << "hidden box face " << p;
  // makeCube's faces: +X, -X, +Y, -Y, +Z, -Z.
  EXPECT_TRUE(got.count(7 + 1)) << "-X face";
  EXPECT_TRUE(got.count(7 + 4)) << "+Z face";
  EXPECT_FALSE(got.count(7 + 0));
  EXPECT_FALSE(got.count(7 + 5));
  expectMatchesRayCast(*vis, rayCastPixels(scene, patchOf, cam, 96, 72));
}

TEST_P(AtlasVisibility, TransparencyCountsOnlyInFrontOfOpaque) {
  // An opaque wall at z = 0; a BLEND quad in front of it (z = 1) and one behind it (z = -1); a MASK
  // quad whose every texel is cut away in front of a box face: the box stays visible, the MASK not.
  Material wall = test::solidMaterial({0.5f, 0.5f, 0.5f, 1});
  Material glass = test::solidMaterial({0.2f, 0.4f, 0.9f, 0.5f}, AlphaMode::Blend);
  Material cutAway = test::solidMaterial({0.9f, 0.1f, 0.1f, 0.2f}, AlphaMode::Mask);
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f), translated(test::makeQuad(0.3f, 1.0f, 1), {-0.4f, 0, 0}),
                                 translated(test::makeQuad(0.3f, -1.0f, 1), {0.4f, 0, 0}),
                                 translated(test::makeQuad(0.4f, 1.5f, 2), {1.8f, 0, 0}),
                                 translated(test::makeCube(0.3f), {1.8f, 0, 0.5f})},
                                {wall, glass, cutAway});
  std::vector<uint32_t> patchOf = pairPatches(scene); // wall 0, glass front 1, glass behind 2, mask 3, box 4..9
  auto atlas = create(scene, patchOf);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  Camera cam = camera({0.5f, 0, 6}, {0.5f, 0, 0});
  auto vis = atlas.value()->visibility({&cam, 1}, 128, 64);
  ASSERT_TRUE(vis.ok()) << vis.error().message;
  std::set<uint32_t> got(vis->begin(), vis->end());
  EXPECT_TRUE(got.count(0));
  EXPECT_TRUE(got.count(1)) << "BLEND quad in front of the wall";
  EXPECT_FALSE(got.count(2)) << "BLEND quad behind the wall";
  EXPECT_FALSE(got.count(3)) << "MASK quad cut away everywhere";
  EXPECT_TRUE(got.count(4 + 4)) << "box face behind the cut-away MASK quad";
  expectMatchesRayCast(*vis, rayCastPixels(scene, patchOf, cam, 128, 64));
}

TEST_P(AtlasVisibility, TwoCamerasSeeTheUnion) {
  // Boxes around the origin; the current view sees one side, the predicted view another.
  Scene scene =
      test::makeScene({translated(test::makeCube(0.4f), {-1.5f, 0, 0}), translated(test::makeCube(0.4f), {1.5f, 0, 0}),
                       translated(test::makeCube(0.4f), {0, 0, -1.5f}), test::makeSphere(0.6f, 8, 12)},
                      {test::solidMaterial({0.6f, 0.6f, 0.6f, 1})});
  std::vector<uint32_t> patchOf = pairPatches(scene);
  auto atlas = create(scene, patchOf);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  Camera views[2] = {camera({0, 1, 5}), camera({5, 1, 0.5f})};
  auto a = atlas.value()->visibility({&views[0], 1}, 64, 64);
  auto b = atlas.value()->visibility({&views[1], 1}, 64, 64);
  auto both = atlas.value()->visibility(views, 64, 64);
  ASSERT_TRUE(a.ok() && b.ok() && both.ok());
  std::vector<uint32_t> merged;
  std::set_union(a->begin(), a->end(), b->begin(), b->end(), std::back_inserter(merged));
  EXPECT_EQ(*both, merged);
  EXPECT_GT(merged.size(), a->size()); // the second view adds patches
  expectMatchesRayCast(*a, rayCastPixels(scene, patchOf, views[0], 64, 64));
  expectMatchesRayCast(*b, rayCastPixels(scene, patchOf, views[1], 64, 64));
}

TEST_P(AtlasVisibility, BadInputIsAnError) {
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f)}, {});
  auto wrongSize = create(scene, {0, 0, 0});
  ASSERT_FALSE(wrongSize.ok());
  EXPECT_NE(wrongSize.error().message.find("3 triangles"), std::string::npos) << wrongSize.error().message;
  auto badId = create(scene, {0, 7});
  ASSERT_FALSE(badId.ok());
  EXPECT_NE(badId.error().message.find("patch 7"), std::string::npos) << badId.error().message;
  auto badSide = create(scene, {0, 0}, {1000, 16});
  EXPECT_FALSE(badSide.ok());
  auto atlas = create(scene, {0, 0});
  ASSERT_TRUE(atlas.ok());
  EXPECT_FALSE(atlas.value()->visibility({}, 64, 64).ok());
  Camera cam = camera({0, 0, 5});
  EXPECT_FALSE(atlas.value()->visibility({&cam, 1}, 0, 64).ok());
}

// The compute method marks every patch the hardware passes mark on a city (opaque walls and
// interiors standing on the sidewalk's plane, glass, a ground under everything): from above, along
// a street (the near plane cuts the ground), and both at once. It may add a few: surfaces that tie
// with the nearest one within MIRAGE_ATLAS_DEPTH_TOLERANCE (the interior floors on the sidewalk's
// plane), which the client's rasterizer may show. Skipped where the device lacks the compute
// raster's atomics.
class AtlasVisibilityMethods : public GpuTest {};

TEST_F(AtlasVisibilityMethods, ComputeMarksTheHardwarePatchesOnACity) {
  if (!context().caps().int64BufferAtomics || !context().caps().int64SharedAtomics)
    GTEST_SKIP() << "no 64-bit buffer and shared atomics: no compute visibility";
  Scene scene = io::generateScene("city", 1, 1).value();
  std::vector<uint32_t> patchOf = pairPatches(scene);
  AtlasShadingConfig config;
  config.visibility = AtlasVisibilityMethod::Compute;
  auto compute = AtlasShading::create(context(), scene, patchOf, config);
  config.visibility = AtlasVisibilityMethod::Hardware;
  auto hardware = AtlasShading::create(context(), scene, patchOf, config);
  ASSERT_TRUE(compute.ok() && hardware.ok());
  Bounds b = scene.worldBounds();
  glm::vec3 centre = b.center(), extent = b.max - b.min;
  Camera above = camera(centre + glm::vec3(0.7f, 0.5f, 0.9f) * extent, centre);
  Camera street = camera(glm::vec3(centre.x, 1.7f, b.min.z + 1.0f), glm::vec3(centre.x, 1.7f, b.max.z));
  Camera views[] = {above, street};
  for (std::span<const Camera> cams :
       {std::span<const Camera>(&views[0], 1), std::span<const Camera>(&views[1], 1), std::span<const Camera>(views)}) {
    auto c = compute.value()->visibility(cams, 160, 90);
    auto h = hardware.value()->visibility(cams, 160, 90);
    ASSERT_TRUE(c.ok() && h.ok());
    EXPECT_GT(h->size(), 100u);
    std::vector<uint32_t> onlyCompute, onlyHardware;
    std::set_difference(c->begin(), c->end(), h->begin(), h->end(), std::back_inserter(onlyCompute));
    std::set_difference(h->begin(), h->end(), c->begin(), c->end(), std::back_inserter(onlyHardware));
    EXPECT_TRUE(onlyHardware.empty()) << cams.size() << " camera(s): " << onlyHardware.size()
                                      << " hardware patches not marked by compute, of " << h->size();
    EXPECT_LE(onlyCompute.size(), h->size() / 50) << cams.size() << " camera(s): " << onlyCompute.size()
                                                  << " compute patches the hardware does not mark, of " << h->size();
  }
}

// The compute method's depth tolerance: a quad coplanar with a wall and inside it counts (either
// rasterizer may round it in front), one 1 % of the distance behind the wall does not.
TEST_F(AtlasVisibilityMethods, ComputeCountsTiesNotSurfacesBehind) {
  if (!context().caps().int64BufferAtomics || !context().caps().int64SharedAtomics)
    GTEST_SKIP() << "no 64-bit buffer and shared atomics: no compute visibility";
  Scene scene = test::makeScene({test::makeQuad(1.0f, 0.0f), translated(test::makeQuad(0.3f, 0.0f), {-0.4f, 0, 0}),
                                 translated(test::makeQuad(0.3f, -0.05f), {0.4f, 0, 0})},
                                {test::solidMaterial({0.8f, 0.8f, 0.8f, 1})});
  std::vector<uint32_t> patchOf = pairPatches(scene); // wall 0, coplanar quad 1, quad behind 2
  AtlasShadingConfig config;
  config.visibility = AtlasVisibilityMethod::Compute;
  auto atlas = AtlasShading::create(context(), scene, patchOf, config);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  Camera cam = camera({0, 0, 5});
  auto vis = atlas.value()->visibility({&cam, 1}, 96, 72);
  ASSERT_TRUE(vis.ok()) << vis.error().message;
  EXPECT_EQ(*vis, (std::vector<uint32_t>{0, 1}));
}
