// Order-independent transparency in the forward renderer (docs/render.md, "Transparency"): the
// linked lists against the sorted reference on geometry that sorting whole objects gets wrong
// (intersecting quads, one self-overlapping mesh), weighted blended OIT within its bound, Mean
// Squared Layers on stacked full-screen layers, pool overflow counted and keeping the nearest
// fragments, the per-pixel cap keeping each hot pixel's nearest 16 without starving the rest of the
// view, a visible set's blended triangles only. Validation stays silent.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "test_scenes.h"
#include "render/render_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kOitSize = 64;

// An n x n grid in the XY plane at z (facing +Z; test::makeGrid), vertex colour `color`: with n
// even a vertex column at x = 0, along which the crossing quads below intersect.
Mesh makeGrid(float halfSize, uint32_t material, glm::vec4 color, int n = 4, float z = 0.0f) {
  Mesh m = test::makeGrid(halfSize, z, material, n);
  m.colors.assign(m.positions.size(), color);
  return m;
}

// Appends `other`'s vertices and triangles to `m` (one mesh, one material).
void append(Mesh& m, const Mesh& other) {
  uint32_t base = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), other.positions.begin(), other.positions.end());
  m.normals.insert(m.normals.end(), other.normals.begin(), other.normals.end());
  m.uv0.insert(m.uv0.end(), other.uv0.begin(), other.uv0.end());
  m.colors.insert(m.colors.end(), other.colors.begin(), other.colors.end());
  for (uint32_t i : other.indices) m.indices.push_back(base + i);
  for (const glm::vec3& p : other.positions) m.bounds.add(p);
}

Material blend(glm::vec4 color) { return test::solidMaterial(color, AlphaMode::Blend, /*doubleSided=*/true); }

// An opaque wall behind two blended quads crossing in an X along the y axis (turned +/-35 degrees
// about it): left of the axis one is in front, right of it the other. Split along the crossing,
// so sorting triangles is exact here, sorting the two objects is not.
Scene crossingQuads() {
  Scene s;
  s.materials = {test::solidMaterial({0.3f, 0.5f, 0.3f, 1.0f}), blend({0.9f, 0.2f, 0.1f, 0.5f}),
                 blend({0.1f, 0.3f, 0.9f, 0.6f})};
  s.meshes = {makeGrid(2.5f, 0, glm::vec4(1)), makeGrid(1.0f, 1, glm::vec4(1)), makeGrid(1.0f, 2, glm::vec4(1))};
  glm::mat4 up = glm::mat4(1.0f);
  s.instances = {{0, glm::translate(up, {0, 0, -1.5f})},
                 {1, glm::rotate(up, glm::radians(35.0f), glm::vec3(0, 1, 0))},
                 {2, glm::rotate(up, glm::radians(-35.0f), glm::vec3(0, 1, 0))}};
  return s;
}

// One mesh overlapping itself: three parallel layers (red, green, blue by vertex colour) listed
// nearest first, so drawing it in its own order blends front to back.
Scene selfOverlapping() {
  Mesh m = makeGrid(1.0f, 0, {1, 0.2f, 0.2f, 1}, 2, 0.6f);
  append(m, makeGrid(0.8f, 0, {0.2f, 1, 0.2f, 1}, 2, 0.3f));
  append(m, makeGrid(0.6f, 0, {0.2f, 0.2f, 1, 1}, 2, 0.0f));
  m.name = "folded";
  return test::makeScene({m}, {blend({1, 1, 1, 0.5f})});
}

// n full-screen blended layers (and nothing else) in front of the camera.
Scene stackedLayers(int n) {
  Scene s;
  s.materials = {blend({0.8f, 0.6f, 0.2f, 0.2f})};
  for (int i = 0; i < n; ++i) s.meshes.push_back(makeGrid(50.0f, 0, glm::vec4(1), 1, -0.1f * float(i)));
  for (uint32_t i = 0; i < s.meshes.size(); ++i) s.instances.push_back({i, glm::mat4(1.0f)});
  return s;
}

ForwardRenderSettings oitSettings(OitMode mode) {
  ForwardRenderSettings s;
  s.base.width = s.base.height = kOitSize;
  s.base.camera.eye = {0.4f, 0.3f, 5.0f};
  s.base.camera.target = {0, 0, 0};
  s.base.camera.fovYDegrees = 45.0f;
  s.base.background = {0.05f, 0.05f, 0.1f, 1};
  s.oit = mode;
  return s;
}

// Linked lists equal the sorted reference; the reference depends on the order (a back-to-front
// "over" of the objects in either order differs from it), so the lists did sort per pixel.
void expectListsMatchSorted(gpu::Context& ctx, const Scene& scene, const std::string& name, double weightedBound) {
  RenderOutput sorted = test::renderForward(ctx, scene, oitSettings(OitMode::Sorted));
  RenderOutput lists = test::renderForward(ctx, scene, oitSettings(OitMode::LinkedList));
  RenderOutput weighted = test::renderForward(ctx, scene, oitSettings(OitMode::Weighted));
  double pLists = psnr(sorted.srgb, lists.srgb), pWeighted = psnr(sorted.srgb, weighted.srgb);
  std::printf("%s: linked list vs sorted %.2f dB, weighted vs sorted %.2f dB; %u fragments, msl %.3f\n", name.c_str(),
              pLists, pWeighted, lists.stats.oit.fragments, lists.stats.oit.msl);
  EXPECT_GE(pLists, 45.0) << name;
  EXPECT_GE(pWeighted, weightedBound) << name;
  EXPECT_LT(pWeighted, 45.0) << name << ": weighted blending is an approximation on several layers";
  EXPECT_GT(lists.stats.oit.fragments, 0u);
  EXPECT_EQ(lists.stats.oit.dropped(), 0u);
  EXPECT_EQ(sorted.stats.oit.fragments, 0u); // counters belong to the linked lists
  test::writeOnFailure(sorted.srgb, name + "_sorted.png");
  test::writeOnFailure(lists.srgb, name + "_lists.png");
  test::writeOnFailure(weighted.srgb, name + "_weighted.png");
}

} // namespace

class ForwardOit : public test::GpuTest {};

TEST_F(ForwardOit, IntersectingQuadsListsMatchSorted) {
  expectListsMatchSorted(context(), crossingQuads(), "crossing", 30.0);
}

TEST_F(ForwardOit, SelfOverlappingMeshListsMatchSorted) {
  expectListsMatchSorted(context(), selfOverlapping(), "folded", 30.0);
}

// The sorted reference is the per-triangle order, not the scene's: listing the quads the other
// way round changes nothing, in any mode.
TEST_F(ForwardOit, ImageIndependentOfSceneOrder) {
  Scene a = crossingQuads(), b = a;
  std::swap(b.instances[1], b.instances[2]);
  for (OitMode mode : {OitMode::LinkedList, OitMode::Sorted, OitMode::Weighted}) {
    double p = psnr(test::renderForward(context(), a, oitSettings(mode)).srgb,
                    test::renderForward(context(), b, oitSettings(mode)).srgb);
    EXPECT_GE(p, 50.0) << toString(mode);
  }
}

// One blended layer: weighted blending is exact (the weight cancels), so it matches too.
TEST_F(ForwardOit, WeightedIsExactForOneLayer) {
  Scene one = crossingQuads();
  one.instances.pop_back();
  double p = psnr(test::renderForward(context(), one, oitSettings(OitMode::Sorted)).srgb,
                  test::renderForward(context(), one, oitSettings(OitMode::Weighted)).srgb);
  EXPECT_GE(p, 45.0);
}

// N layers over every pixel: every pixel gets N fragments, so MSL = N^2; past the 16-layer cap the
// farthest N - 16 of each pixel are dropped and counted (MSL counts every fragment, listed or not).
TEST_F(ForwardOit, MeanSquaredLayersOfStackedLayers) {
  const uint64_t pixels = uint64_t(kOitSize) * kOitSize;
  ForwardRenderSettings s = oitSettings(OitMode::LinkedList);
  s.oitNodesPerPixel = 32; // every fragment fits
  for (int n : {1, 5, 20}) {
    RenderOutput out = test::renderForward(context(), stackedLayers(n), s);
    const OitStats& st = out.stats.oit;
    EXPECT_EQ(st.coveredPixels, pixels) << n;
    EXPECT_EQ(st.fragments, uint64_t(n) * pixels) << n;
    EXPECT_DOUBLE_EQ(st.msl, double(n) * n) << n;
    EXPECT_EQ(st.poolOverflow, 0u) << n;
    EXPECT_EQ(st.capDropped, uint64_t(std::max(n - MIRAGE_OIT_MAX_LAYERS, 0)) * pixels) << n;
    EXPECT_EQ(st.layersDropped, 0u) << n; // the lists never outgrow the resolve's layers
  }
}

// A pool of 2 nodes per pixel under 5 layers: the excess is counted as dropped, the frame
// completes, and the image is still the layers' colour over the background (fewer of them).
TEST_F(ForwardOit, PoolOverflowIsCountedAndNeverHangs) {
  const uint64_t pixels = uint64_t(kOitSize) * kOitSize;
  ForwardRenderSettings s = oitSettings(OitMode::LinkedList);
  s.oitNodesPerPixel = 2;
  RenderOutput out = test::renderForward(context(), stackedLayers(5), s);
  const OitStats& st = out.stats.oit;
  EXPECT_EQ(st.fragments, 5 * pixels);
  EXPECT_EQ(st.poolOverflow, 3 * pixels);
  EXPECT_EQ(st.dropped(), 3 * pixels);
  EXPECT_GT(st.coveredPixels, 0u);
  s.oitNodesPerPixel = 0;
  auto renderer = ForwardRenderer::create(context(), stackedLayers(1));
  ASSERT_TRUE(renderer.ok());
  auto bad = (*renderer)->render(s);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("nodes per pixel"), std::string::npos) << bad.error().message;
}

// Full-screen layers of distinct colours, layer i at z = -0.1 i (layer 0 nearest), listed (and so
// drawn) farthest first; the k nearest only with `nearest`, and all of them transparent when k = 0.
Scene colouredLayers(int n, int nearest) {
  Scene s;
  s.materials = {blend({1, 1, 1, nearest == 0 ? 0.0f : 0.3f})};
  for (int i = std::max(nearest, 1) - 1; i >= 0; --i) {
    float h = float(i) / float(n) * 6.2831853f;
    glm::vec4 color(0.5f + 0.45f * std::cos(h), 0.5f + 0.45f * std::cos(h - 2.094f),
                    0.5f + 0.45f * std::cos(h + 2.094f), 1.0f);
    s.meshes.push_back(makeGrid(50.0f, 0, color, 1, -0.1f * float(i)));
  }
  for (uint32_t i = 0; i < s.meshes.size(); ++i) s.instances.push_back({i, glm::mat4(1.0f)});
  return s;
}

// The pool's overflow rule (oit_list.glsl): under 5 layers a pool of 2 nodes per pixel keeps each
// pixel's nearest fragments, the farthest dropped, though the far layers are drawn first (and so
// take the pool): every pixel equals the image of its k nearest layers alone, the k summing to the
// pool. The colours stored beside the nodes follow their replacements.
TEST_F(ForwardOit, PoolOverflowKeepsEachPixelsNearestLayers) {
  constexpr int kLayers = 5;
  constexpr uint32_t kPool = 2;
  ForwardRenderSettings s = oitSettings(OitMode::LinkedList);
  s.oitNodesPerPixel = 8; // the candidates: nothing dropped
  std::vector<ImageRGBA8> nearest;
  for (int k = 0; k <= kLayers; ++k)
    nearest.push_back(test::renderForward(context(), colouredLayers(kLayers, k), s).srgb);
  s.oitNodesPerPixel = kPool;
  RenderOutput out = test::renderForward(context(), colouredLayers(kLayers, kLayers), s);
  EXPECT_EQ(out.stats.oit.poolOverflow, uint64_t(kLayers - kPool) * kOitSize * kOitSize);
  uint32_t unmatched = 0, kept = 0;
  for (uint32_t y = 0; y < kOitSize; ++y)
    for (uint32_t x = 0; x < kOitSize; ++x) {
      int best = -1, bestDiff = 1 << 30;
      for (int k = 0; k <= kLayers; ++k) {
        int diff = 0;
        for (int c = 0; c < 3; ++c)
          diff = std::max(diff, std::abs(int(out.srgb.at(x, y)[c]) - int(nearest[size_t(k)].at(x, y)[c])));
        if (diff < bestDiff) bestDiff = diff, best = k;
      }
      if (bestDiff > 1)
        ++unmatched;
      else
        kept += uint32_t(best);
    }
  std::printf("pool of %u under %d layers: %u pixels match no nearest-k image, %u fragments kept\n", kPool, kLayers,
              unmatched, kept);
  // Fragments of one pixel racing past the pool may miss a node still being linked (the
  // replacement rule is approximate under contention, docs/render.md), which the threads of a
  // loaded machine can produce: a few pixels may keep another set; dropping on arrival fails all.
  EXPECT_LE(unmatched, kOitSize * kOitSize / 100u);
  EXPECT_LE(std::abs(int64_t(kept) - int64_t(kPool * kOitSize * kOitSize)),
            int64_t(kPool * kOitSize * kOitSize / 100u));
  test::writeOnFailure(out.srgb, "pool_overflow.png");
}

// A hot region: 40 layers over the left half of the view (listed in a shuffled depth order), 2
// nearer full-screen layers over all of it, a pool of 10 nodes per pixel (less than the left
// half's fragments alone, enough for 16 per left pixel and 2 per right one). The per-pixel cap
// (oit_list.glsl) gives the left pixels no more than 16 nodes, so the right half keeps both its
// layers, and each left pixel keeps its nearest 16: the image of the 2 full-screen layers and the
// 14 nearest of the stack alone. MSL counts every fragment: (42^2 + 2^2) / 2 per pixel.
TEST_F(ForwardOit, PerPixelCapKeepsTheNearestAndSparesThePool) {
  constexpr int kHot = 40, kFull = 2, kKept = MIRAGE_OIT_MAX_LAYERS - kFull;
  const uint64_t pixels = uint64_t(kOitSize) * kOitSize;
  auto scene = [](int hotLayers) {
    Scene s;
    for (int i = 0; i < kHot + kFull; ++i) {
      float h = float(i) / float(kHot + kFull) * 6.2831853f;
      s.materials.push_back(blend({0.5f + 0.45f * std::cos(h), 0.5f + 0.45f * std::cos(h - 2.094f),
                                   0.5f + 0.45f * std::cos(h + 2.094f), 0.15f}));
    }
    // Hot layer i at z = -0.05 i (0 nearest) over x < 0: the edge x = 0 projects to the view's
    // middle at every depth; only the `hotLayers` nearest are in the scene.
    for (int k = 0; k < kHot; ++k) {
      int i = (k * 17) % kHot; // a shuffled draw order
      if (i >= hotLayers) continue;
      s.meshes.push_back(test::makeGrid(50.0f, -0.05f * float(i), uint32_t(i), 1));
      s.instances.push_back({uint32_t(s.meshes.size() - 1), glm::translate(glm::mat4(1.0f), {-50.0f, 0, 0})});
    }
    for (int j = 0; j < kFull; ++j) {
      s.meshes.push_back(test::makeGrid(50.0f, 0.5f + 0.1f * float(j), uint32_t(kHot + j), 1));
      s.instances.push_back({uint32_t(s.meshes.size() - 1), glm::mat4(1.0f)});
    }
    return s;
  };
  ForwardRenderSettings s = oitSettings(OitMode::LinkedList);
  s.base.camera.eye = {0.0f, 0.0f, 5.0f};
  s.oitNodesPerPixel = 32; // the reference: nothing dropped
  RenderOutput nearest = test::renderForward(context(), scene(kKept), s);
  ASSERT_EQ(nearest.stats.oit.dropped(), 0u);
  s.oitNodesPerPixel = 10;
  RenderOutput out = test::renderForward(context(), scene(kHot), s);
  const OitStats& st = out.stats.oit;
  const uint64_t hot = pixels / 2;
  EXPECT_EQ(st.coveredPixels, pixels);
  EXPECT_EQ(st.fragments, hot * (kHot + kFull) + (pixels - hot) * kFull);
  EXPECT_EQ(st.poolOverflow, 0u);
  EXPECT_EQ(st.capDropped, hot * (kHot + kFull - MIRAGE_OIT_MAX_LAYERS));
  EXPECT_EQ(st.layersDropped, 0u);
  EXPECT_DOUBLE_EQ(st.msl, double((kHot + kFull) * (kHot + kFull) + kFull * kFull) / 2.0);
  uint32_t unmatched[2] = {};
  for (uint32_t y = 0; y < kOitSize; ++y)
    for (uint32_t x = 0; x < kOitSize; ++x) {
      int diff = 0;
      for (int c = 0; c < 3; ++c)
        diff = std::max(diff, std::abs(int(out.srgb.at(x, y)[c]) - int(nearest.srgb.at(x, y)[c])));
      if (diff > 1) ++unmatched[x < kOitSize / 2 ? 0 : 1];
    }
  std::printf("hot half: %u of %llu pixels differ from their nearest 16; other half: %u\n", unmatched[0],
              (unsigned long long)hot, unmatched[1]);
  // Fragments of one pixel racing past the cap may miss a node still being linked (docs/render.md).
  EXPECT_LE(unmatched[0], uint32_t(hot / 100));
  EXPECT_EQ(unmatched[1], 0u); // the pool was not starved: every layer of the other half kept
  test::writeOnFailure(out.srgb, "cap.png");
  test::writeOnFailure(nearest.srgb, "cap_nearest.png");
}

// Stereo: each eye's fragments land in its half of the lists (the pixel of the shared target).
TEST_F(ForwardOit, StereoCountsBothEyes) {
  const uint64_t pixels = uint64_t(kOitSize) * kOitSize;
  ForwardRenderSettings s = oitSettings(OitMode::LinkedList);
  s.stereoIpd = 0.064f;
  RenderOutput out = test::renderForward(context(), stackedLayers(3), s);
  EXPECT_EQ(out.stats.oit.coveredPixels, 2 * pixels);
  EXPECT_DOUBLE_EQ(out.stats.oit.msl, 9.0);
}

// A visible set (setVisibleTriangles, a view cell's PVS) in every mode: the blended passes draw
// only the listed triangles, as a renderer of the scene cut down to them draws (the lists and the
// weighted pass from the set's index ranges, the sorted reference sorting only listed triangles).
TEST_F(ForwardOit, VisibleTrianglesDrawOnlyListedBlendedTriangles) {
  const Scene scene = crossingQuads(); // 32 triangles per mesh: wall 0..31, quads 32..63, 64..95
  // The wall, two runs of the first quad, the middle of the second.
  std::vector<uint32_t> ids;
  auto list = [&](uint32_t first, uint32_t end) {
    for (uint32_t t = first; t < end; ++t) ids.push_back(t);
  };
  list(0, 32), list(32, 40), list(48, 64), list(72, 88);
  Scene cut = scene;
  auto keep = [&](uint32_t mesh, uint32_t first, uint32_t end) {
    const std::vector<uint32_t>& all = scene.meshes[mesh].indices;
    cut.meshes[mesh].indices.insert(cut.meshes[mesh].indices.end(), all.begin() + first * 3, all.begin() + end * 3);
  };
  cut.meshes[1].indices.clear(), cut.meshes[2].indices.clear();
  keep(1, 0, 8), keep(1, 16, 32), keep(2, 8, 24);

  auto renderer = ForwardRenderer::create(context(), scene);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ASSERT_TRUE((*renderer)->setVisibleTriangles(&ids).ok());
  for (OitMode mode : {OitMode::LinkedList, OitMode::Weighted, OitMode::Sorted}) {
    auto listed = (*renderer)->render(oitSettings(mode));
    ASSERT_TRUE(listed.ok()) << listed.error().message;
    RenderOutput expected = test::renderForward(context(), cut, oitSettings(mode));
    RenderOutput full = test::renderForward(context(), scene, oitSettings(mode));
    EXPECT_EQ(listed->stats.trianglesSubmitted, ids.size()) << toString(mode);
    EXPECT_EQ(listed->stats.oit.fragments, expected.stats.oit.fragments) << toString(mode);
    EXPECT_GE(psnr(expected.srgb, listed->srgb), 60.0) << toString(mode);
    EXPECT_LT(psnr(full.srgb, listed->srgb), 40.0) << toString(mode) << ": the unlisted triangles were drawn";
    test::writeOnFailure(listed->srgb, std::string("visible_") + toString(mode) + ".png");
  }
}
