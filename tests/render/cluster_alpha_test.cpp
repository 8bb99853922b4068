// Alpha MASK and BLEND in the cluster-LOD renderer (docs/render.md, "Alpha"): a small scene of
// tessellated panels (an opaque wall, a masked checker panel seen from behind, two overlapping
// blended panels) baked in memory, rendered by every backend and compared with the forward
// renderer, which alpha-tests in its fragment shader and sorts blended instances back to front.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/io/image_io.h"
#include "mirage/io/import.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "test_scenes.h"
#include "render/cluster_test_util.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::availableRasterBackends;
using mirage::test::renderCluster;
using mirage::test::writeOnFailure;

namespace {

constexpr uint32_t kAlphaSize = 192;

// Wall (opaque, z = -1); masked checker panel (z = 0, double-sided, turned to show its back, so a
// normal cone would cull it if cones ignored double-sidedness); two blended panels overlapping in
// the middle (z = 0.6 blue, z = 1.1 yellow). `swapBlend` lists the blended panels the other way
// round (draw and list order), which must not change the image.
Scene alphaScene(bool swapBlend) {
  Scene s;
  s.materials = {test::solidMaterial({0.25f, 0.6f, 0.3f, 1.0f}, AlphaMode::Opaque),
                 test::solidMaterial({0.9f, 0.2f, 0.2f, 1.0f}, AlphaMode::Mask, /*doubleSided=*/true),
                 test::solidMaterial({0.1f, 0.3f, 0.9f, 0.5f}, AlphaMode::Blend),
                 test::solidMaterial({0.9f, 0.8f, 0.1f, 0.4f}, AlphaMode::Blend)};
  s.materials[1].alphaCutoff = 0.5f;
  s.materials[1].baseColorTexture = 0;
  s.textures.push_back(test::checkerCutout());
  s.meshes = {test::makeGrid(2.5f, -1.0f, 0), test::makeGrid(1.2f, 0.0f, 1), test::makeGrid(0.8f, 0.0f, 2),
              test::makeGrid(0.8f, 0.0f, 3)};
  glm::mat4 turned = glm::rotate(glm::mat4(1.0f), glm::radians(180.0f), glm::vec3(0, 1, 0));
  Instance blue{2, glm::translate(glm::mat4(1.0f), {-0.45f, 0.1f, 0.6f})};
  Instance yellow{3, glm::translate(glm::mat4(1.0f), {0.45f, -0.1f, 1.1f})};
  s.instances = {{0, glm::mat4(1.0f)}, {1, turned}};
  if (swapBlend) {
    s.instances.push_back(yellow);
    s.instances.push_back(blue);
  } else {
    s.instances.push_back(blue);
    s.instances.push_back(yellow);
  }
  return s;
}

ClusterRenderSettings alphaSettings(RasterBackend raster) {
  ClusterRenderSettings s;
  s.base.width = s.base.height = kAlphaSize;
  s.base.camera.eye = {0.3f, 0.4f, 6.0f};
  s.base.camera.target = {0.0f, 0.0f, 0.0f};
  s.base.camera.fovYDegrees = 45.0f;
  s.base.background = {0.05f, 0.05f, 0.1f, 1};
  s.tauPixels = 0.5f;
  s.raster = raster;
  s.occlusionCulling = false;
  return s;
}

// The forward renderer's image of `scene`.
ImageRGBA8 forwardImage(gpu::Context& ctx, const Scene& scene, const RenderSettings& s) {
  return test::renderForward(ctx, scene, {.base = s}).srgb;
}

bool hasPass(const ClusterRenderOutput& out, const char* name) {
  for (const auto& t : out.image.stats.passTimes)
    if (t.name == name) return true;
  return false;
}

// The hardware and hybrid blend rasters against the compute one (docs/render.md, "Blend rasters"),
// and the compute one with every triangle and with no triangle through the blend queue (exactly
// the default's fragments and image), over each opaque backend: the same blend clusters, the same fragments up to edge
// and depth-tie rules (the compute raster's canonical edge order and its own depth interpolation against the hardware's
// top-left rule and interpolator: a sample exactly on an edge, or a pane meeting a wall at equal depth, may fall the
// other way), hence the same image. `hybridThreshold` is chosen per scene so hybrid really splits (asserted where
// `expectSplit`).
void expectBlendRastersAgree(gpu::Context& ctx, const lod::LodAsset& asset, ClusterRenderSettings s,
                             const std::string& scene, bool expectSplit) {
  if (!ctx.caps().fragmentStoresAndAtomics) GTEST_SKIP() << "no fragment stores: compute blend raster only";
  auto renderer = ClusterRenderer::create(ctx, asset);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  std::vector<RasterBackend> opaque{RasterBackend::Indirect};
  if (ctx.caps().meshShader) opaque.push_back(RasterBackend::Mesh);
  if (ctx.caps().int64BufferAtomics) opaque.push_back(RasterBackend::Compute);
  for (RasterBackend b : opaque) {
    s.raster = b;
    s.blendRaster = BlendRaster::Compute;
    auto reference = (*renderer)->render(s);
    ASSERT_TRUE(reference.ok()) << reference.error().message;
    const ClusterStats& ref = reference->stats;
    ASSERT_GT(ref.clustersBlend, 0u) << scene;
    ASSERT_GT(ref.oitFragments, 0u) << scene;
    EXPECT_EQ(ref.blendRaster, BlendRaster::Compute);
    EXPECT_EQ(ref.clustersBlendHardware, 0u);
    // The compute blend raster with every blended triangle through the blend queue, and with none:
    // exactly the fragments and the image of the default (docs/render.md, "Blend rasters").
    for (float queuePixels : {0.0f, float(INFINITY)}) {
      if (!ctx.caps().int64BufferAtomics) break;
      s.blendQueuePixels = queuePixels;
      auto q = (*renderer)->render(s);
      ASSERT_TRUE(q.ok()) << q.error().message;
      std::printf("%s, %s + blend compute, queue over %.0f px: %u triangles queued, %u fragments (default %u)\n",
                  scene.c_str(), toString(b), queuePixels, q->stats.blendQueueTriangles, q->stats.oitFragments,
                  ref.oitFragments);
      if (queuePixels == 0.0f) {
        EXPECT_GT(q->stats.blendQueueTriangles, 0u) << scene;
      } else {
        EXPECT_EQ(q->stats.blendQueueTriangles, 0u) << scene;
      }
      EXPECT_EQ(q->stats.oitFragments, ref.oitFragments) << scene << " " << toString(b);
      EXPECT_TRUE(q->image.srgb.pixels == reference->image.srgb.pixels)
          << scene << " " << toString(b) << " queue over " << queuePixels << " px";
      writeOnFailure(q->image.srgb, scene + "_" + toString(b) + "_queue_" + std::to_string(int(queuePixels)) + ".png");
    }
    s.blendQueuePixels = ClusterRenderSettings{}.blendQueuePixels;
    for (BlendRaster blend : {BlendRaster::Hybrid, BlendRaster::Hardware}) {
      s.blendRaster = blend;
      auto out = (*renderer)->render(s);
      ASSERT_TRUE(out.ok()) << out.error().message;
      const ClusterStats& st = out->stats;
      double p = psnr(reference->image.srgb, out->image.srgb);
      int64_t diff = int64_t(st.oitFragments) - int64_t(ref.oitFragments);
      std::printf("%s, %s + blend %s: %u of %u blend clusters by hardware, %u fragments (compute %u, %+lld), "
                  "PSNR vs compute blend %.2f dB\n",
                  scene.c_str(), toString(b), toString(blend), st.clustersBlendHardware, st.clustersBlend,
                  st.oitFragments, ref.oitFragments, (long long)diff, p);
      EXPECT_EQ(st.blendRaster, blend);
      EXPECT_EQ(st.clustersBlend, ref.clustersBlend) << scene << " " << toString(blend);
      if (blend == BlendRaster::Hardware) {
        EXPECT_EQ(st.clustersBlendHardware, st.clustersBlend);
      }
      if (blend == BlendRaster::Hybrid && expectSplit) {
        EXPECT_GT(st.clustersBlendHardware, 0u) << scene;
        EXPECT_LT(st.clustersBlendHardware, st.clustersBlend) << scene;
      }
      // Edge and depth-tie rules only: a fraction of a percent of the fragments.
      EXPECT_LE(std::abs(diff), int64_t(ref.oitFragments / 200 + 4)) << scene << " " << toString(blend);
      EXPECT_EQ(st.oitPoolOverflow, ref.oitPoolOverflow);
      EXPECT_GE(p, 50.0) << scene << " " << toString(b) << " + blend " << toString(blend);
      writeOnFailure(out->image.srgb, scene + "_" + toString(b) + "_blend_" + toString(blend) + ".png");
    }
  }
}

} // namespace

class ClusterAlpha : public test::GpuTest {};

// Blend rasters on the panel scene (two overlapping blended panels over an opaque wall and a
// masked panel; similar triangle sizes, so hybrid's split is asserted on the city below).
TEST_F(ClusterAlpha, HardwareBlendRasterMatchesCompute) {
  lod::LodAsset asset = test::bakeScene(alphaScene(false));
  ASSERT_FALSE(asset.dags.empty());
  expectBlendRastersAgree(context(), asset, alphaSettings(RasterBackend::Auto), "panels", /*expectSplit=*/false);
}

// Khronos AlphaBlendModeTest (textured BLEND quads over opaque and masked ones).
TEST_F(ClusterAlpha, HardwareBlendRasterMatchesComputeOnKhronosAlphaBlendModeTest) {
  MIRAGE_REQUIRE_DATA(path, "khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  lod::LodAsset asset = test::bakeScene(*scene);
  ASSERT_FALSE(asset.dags.empty());
  ClusterRenderSettings s = alphaSettings(RasterBackend::Auto);
  s.base.width = 240;
  s.base.height = 135;
  s.base.camera = autoCamera(asset.scene.worldBounds(), 240.0f / 135.0f);
  s.tauPixels = 0.01f;
  expectBlendRastersAgree(context(), asset, s, "khronos", /*expectSplit=*/false);
}

// A small generated city at street level (glass panes: double-sided BLEND in window reveals, in
// front of the hollow shells' far walls): many blend clusters, near and far, so hybrid splits.
TEST_F(ClusterAlpha, HardwareBlendRasterMatchesComputeOnCity) {
  io::CityOptions o;
  o.blocks = 3;
  o.lotsPerBlockSide = 1;
  o.buildingVariants = 2;
  o.minFloors = 2;
  o.maxFloors = 4;
  o.interiors = false;
  lod::LodAsset asset = test::bakeScene(io::generateCity(o));
  ASSERT_FALSE(asset.dags.empty());
  ClusterRenderSettings s = alphaSettings(RasterBackend::Auto);
  s.base.width = 256;
  s.base.height = 160;
  s.base.camera.eye = {21.0f, 1.7f, -50.0f}; // in a street, looking down it past three blocks
  s.base.camera.target = {25.0f, 6.0f, 40.0f};
  s.base.camera.fovYDegrees = 60.0f;
  s.hybridThreshold = 6.0f;
  expectBlendRastersAgree(context(), asset, s, "city", /*expectSplit=*/true);
}

// Every backend: the forward renderer's image (holes of the masked panel show the wall; blended
// panels tint what lies behind them, sorted per pixel), far from the image with either alpha mode
// ignored; blended clusters are drawn into the transparency lists, none dropped.
TEST_F(ClusterAlpha, MaskAndBlendMatchForward) {
  lod::LodAsset asset = test::bakeScene(alphaScene(false));
  ASSERT_FALSE(asset.dags.empty());
  Scene reference = lod::levelZeroScene(asset);
  ImageRGBA8 fwd = forwardImage(context(), reference, alphaSettings(RasterBackend::Auto).base);
  // Mask ignored (opaque) and blend ignored (opaque): both must be visibly wrong.
  Scene maskOpaque = reference, blendOpaque = reference;
  maskOpaque.materials[1].alphaMode = AlphaMode::Opaque;
  blendOpaque.materials[2].alphaMode = blendOpaque.materials[3].alphaMode = AlphaMode::Opaque;
  double maskIgnored = psnr(fwd, forwardImage(context(), maskOpaque, alphaSettings(RasterBackend::Auto).base));
  double blendIgnored = psnr(fwd, forwardImage(context(), blendOpaque, alphaSettings(RasterBackend::Auto).base));
  std::printf("forward vs mask ignored %.1f dB, vs blend ignored %.1f dB\n", maskIgnored, blendIgnored);
  EXPECT_LT(maskIgnored, 30.0);
  EXPECT_LT(blendIgnored, 30.0);
  for (RasterBackend b : availableRasterBackends(context())) {
    ClusterRenderSettings s = alphaSettings(b);
    if (b == RasterBackend::Hybrid) s.hybridThreshold = 0.0f; // every cluster through the fragment atomics
    ClusterRenderOutput out = renderCluster(context(), asset, s);
    double p = psnr(fwd, out.image.srgb);
    std::printf("%s: %u clusters (%u blend), %u blended fragments, PSNR vs forward %.2f dB\n", toString(b),
                out.stats.clustersDrawn, out.stats.clustersBlend, out.stats.oitFragments, p);
    EXPECT_GE(p, 35.0) << toString(b);
    EXPECT_GT(out.stats.clustersBlend, 0u);
    EXPECT_GT(out.stats.oitFragments, 0u);
    EXPECT_EQ(out.stats.oitPoolOverflow + out.stats.oitLayersDropped, 0u);
    EXPECT_EQ(out.stats.clustersOverflow, 0u);
    EXPECT_TRUE(hasPass(out, "blend") && hasPass(out, "composite"));
    writeOnFailure(out.image.srgb, std::string("alpha_") + toString(b) + ".png");
  }
  writeOnFailure(fwd, "alpha_forward.png");
}

// The blended panels listed in the other order: the same image (the composite sorts per pixel),
// on every backend; and the masked, double-sided panel seen from behind is not cone-culled.
TEST_F(ClusterAlpha, BlendIsIndependentOfOrder) {
  lod::LodAsset a = test::bakeScene(alphaScene(false)), b = test::bakeScene(alphaScene(true));
  ASSERT_FALSE(a.dags.empty() || b.dags.empty());
  for (RasterBackend backend : availableRasterBackends(context())) {
    ClusterRenderOutput outA = renderCluster(context(), a, alphaSettings(backend));
    ClusterRenderOutput outB = renderCluster(context(), b, alphaSettings(backend));
    double p = psnr(outA.image.srgb, outB.image.srgb);
    std::printf("%s: order swapped PSNR %.2f dB, %u cone-culled\n", toString(backend), p,
                outA.stats.clustersBackfaceCulled);
    EXPECT_GE(p, 60.0) << toString(backend);
    // Only the single-sided wall and blended panels face the camera; nothing faces away.
    EXPECT_EQ(outA.stats.clustersBackfaceCulled, 0u);
    writeOnFailure(outA.image.srgb, std::string("order_a_") + toString(backend) + ".png");
    writeOnFailure(outB.image.srgb, std::string("order_b_") + toString(backend) + ".png");
  }
}

// The masked panel shows its back: double-sided, its clusters pass the normal-cone test (the image
// is held to the forward renderer above); made single-sided, the cones drop them, as the forward
// renderer's back-face culling drops their triangles.
TEST_F(ClusterAlpha, MaskedDoubleSidedIsNotConeCulled) {
  Scene scene = alphaScene(false);
  lod::LodAsset asset = test::bakeScene(scene);
  scene.materials[1].doubleSided = false;
  lod::LodAsset singleSided = test::bakeScene(scene);
  ASSERT_FALSE(asset.dags.empty() || singleSided.dags.empty());
  ClusterRenderOutput both = renderCluster(context(), asset, alphaSettings(RasterBackend::Auto));
  ClusterRenderOutput one = renderCluster(context(), singleSided, alphaSettings(RasterBackend::Auto));
  EXPECT_EQ(both.stats.clustersBackfaceCulled, 0u);
  EXPECT_GT(one.stats.clustersBackfaceCulled, 0u);
  EXPECT_LT(psnr(both.image.srgb, one.image.srgb), 30.0); // the panel is gone
}

// Occlusion culling with blended instances (they own no pixels, so they are always late and
// HZB-tested in phase 2) and a masked occluder: the image equals the one without occlusion.
TEST_F(ClusterAlpha, OcclusionKeepsAlphaImage) {
  if (!context().caps().int64BufferAtomics) GTEST_SKIP() << "no 64-bit buffer atomics";
  lod::LodAsset asset = test::bakeScene(alphaScene(false));
  ASSERT_FALSE(asset.dags.empty());
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = alphaSettings(RasterBackend::Compute);
  auto off = (*r)->render(s);
  ASSERT_TRUE(off.ok());
  s.occlusionCulling = true;
  for (int frame = 0; frame < 2; ++frame) {
    auto on = (*r)->render(s);
    ASSERT_TRUE(on.ok());
    EXPECT_GE(psnr(on->image.srgb, off->image.srgb), 60.0) << "frame " << frame;
    EXPECT_EQ(on->stats.clustersBlend, off->stats.clustersBlend);
  }
}

// Blended layers beyond the limits: 18 stacked half-transparent panels. Over part of the view, a
// pixel keeps its nearest MIRAGE_OIT_MAX_LAYERS (16) and the rest are counted; over the whole view,
// the node pool (4 fragments per pixel on average) overflows too and counts its excess.
TEST_F(ClusterAlpha, CountsFragmentsBeyondTheLimits) {
  if (!context().caps().int64BufferAtomics) GTEST_SKIP() << "no 64-bit buffer atomics";
  for (float halfSize : {0.4f, 10.0f}) {
    Scene s;
    s.materials = {test::solidMaterial({0.9f, 0.3f, 0.2f, 0.2f}, AlphaMode::Blend)};
    s.meshes = {test::makeGrid(halfSize, 0.0f, 0, 2)};
    for (int i = 0; i < 18; ++i) s.instances.push_back({0, glm::translate(glm::mat4(1.0f), {0, 0, 0.05f * float(i)})});
    lod::LodAsset asset = test::bakeScene(s);
    ASSERT_FALSE(asset.dags.empty());
    ClusterRenderSettings cs = alphaSettings(RasterBackend::Compute);
    cs.base.camera.eye = {0.0f, 0.0f, 6.0f}; // on the axis: the panels' projections nest
    cs.base.width = cs.base.height = 48;
    ClusterRenderOutput out = renderCluster(context(), asset, cs);
    std::printf("half size %.1f: %u fragments, %u beyond the pool, %u beyond 16 layers\n", halfSize,
                out.stats.oitFragments, out.stats.oitPoolOverflow, out.stats.oitLayersDropped);
    EXPECT_EQ(out.stats.clustersBlend % 18, 0u);
    EXPECT_GT(out.stats.clustersBlend, 0u);
    if (halfSize < 1.0f) {
      EXPECT_EQ(out.stats.oitPoolOverflow, 0u);
      EXPECT_GT(out.stats.oitLayersDropped, 0u);
      EXPECT_LE(out.stats.oitLayersDropped * 9, out.stats.oitFragments); // at most 2 of every 18
    } else {
      EXPECT_EQ(out.stats.oitFragments, 18u * 48 * 48); // every pixel under every panel
      // The 2 past each pixel's cap of 16 take no node; 16 per pixel ask the pool of 4.
      EXPECT_EQ(out.stats.oitLayersDropped, 2u * 48 * 48);
      EXPECT_EQ(out.stats.oitPoolOverflow, 16u * 48 * 48 - 4u * 48 * 48);
    }
  }
}

// Mean Squared Layers (the shared list code, oit_list.glsl): 3 panels over the whole view put 3
// fragments in every pixel's list, so msl = 9 exactly, with nothing dropped; and the forward
// renderer's linked lists agree on the image of the same panels.
TEST_F(ClusterAlpha, MeanSquaredLayersOfStackedPanels) {
  Scene s;
  s.materials = {test::solidMaterial({0.9f, 0.3f, 0.2f, 0.3f}, AlphaMode::Blend)};
  s.meshes = {test::makeGrid(10.0f, 0.0f, 0, 2)};
  for (int i = 0; i < 3; ++i) s.instances.push_back({0, glm::translate(glm::mat4(1.0f), {0, 0, 0.05f * float(i)})});
  lod::LodAsset asset = test::bakeScene(s);
  ASSERT_FALSE(asset.dags.empty());
  ClusterRenderSettings cs = alphaSettings(RasterBackend::Auto);
  cs.base.camera.eye = {0.0f, 0.0f, 6.0f};
  cs.base.width = cs.base.height = 48;
  ClusterRenderOutput out = renderCluster(context(), asset, cs);
  EXPECT_EQ(out.stats.oitFragments, 3u * 48 * 48);
  EXPECT_EQ(out.stats.oitPoolOverflow + out.stats.oitLayersDropped, 0u);
  EXPECT_DOUBLE_EQ(out.stats.msl, 9.0);
  double p = psnr(forwardImage(context(), s, cs.base), out.image.srgb);
  std::printf("3 stacked panels: msl %.3f, PSNR vs forward linked lists %.2f dB\n", out.stats.msl, p);
  EXPECT_GE(p, 45.0);
}

// Khronos AlphaBlendModeTest (OPAQUE, BLEND and MASK at several cutoffs, textured): the cluster
// renderer matches the forward renderer of the same meshes, which alpha ignored would not.
TEST_F(ClusterAlpha, KhronosAlphaBlendModeTestMatchesForward) {
  MIRAGE_REQUIRE_DATA(path, "khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  lod::LodAsset asset = test::bakeScene(*scene);
  ASSERT_FALSE(asset.dags.empty());
  Scene reference = lod::levelZeroScene(asset);
  ClusterRenderSettings s = alphaSettings(RasterBackend::Auto);
  s.base.width = 240;
  s.base.height = 135;
  s.base.camera = autoCamera(reference.worldBounds(), 240.0f / 135.0f);
  s.tauPixels = 0.01f;
  ImageRGBA8 fwd = forwardImage(context(), reference, s.base);
  Scene ignored = reference; // what the cluster renderer drew before: every material opaque
  for (Material& m : ignored.materials) m.alphaMode = AlphaMode::Opaque;
  double ignoredPsnr = psnr(fwd, forwardImage(context(), ignored, s.base));
  std::printf("AlphaBlendModeTest with alpha ignored: %.2f dB\n", ignoredPsnr);
  EXPECT_LT(ignoredPsnr, 30.0);
  for (RasterBackend b : availableRasterBackends(context())) {
    s.raster = b;
    ClusterRenderOutput out = renderCluster(context(), asset, s);
    double p = psnr(fwd, out.image.srgb);
    std::printf("AlphaBlendModeTest %s: %u blend clusters, PSNR vs forward %.2f dB\n", toString(b),
                out.stats.clustersBlend, p);
    EXPECT_GE(p, 38.0) << toString(b);
    EXPECT_GT(out.stats.clustersBlend, 0u);
    writeOnFailure(out.image.srgb, std::string("khronos_") + toString(b) + ".png");
  }
  writeOnFailure(fwd, "khronos_forward.png");
}

// Opaque-only scenes run no transparency pass and allocate no lists (the cost of BLEND support
// is zero there); the image is the existing renderer's (SmallTauMatchesForward* and the golden
// tests hold it to the forward renderer).
TEST_F(ClusterAlpha, OpaqueScenesRunNoTransparencyPass) {
  Scene s = alphaScene(false);
  for (Material& m : s.materials) m.alphaMode = AlphaMode::Opaque;
  lod::LodAsset asset = test::bakeScene(s);
  ASSERT_FALSE(asset.dags.empty());
  for (RasterBackend b : availableRasterBackends(context())) {
    ClusterRenderOutput out = renderCluster(context(), asset, alphaSettings(b));
    EXPECT_FALSE(hasPass(out, "blend") || hasPass(out, "composite")) << toString(b);
    EXPECT_EQ(out.stats.clustersBlend, 0u);
    EXPECT_EQ(out.stats.oitFragments, 0u);
  }
}

// Transparency off (the viewer's switch): the blend raster and composite do not run, and the image
// is the scene without its blended panels (forward renderer), not the image with them.
TEST_F(ClusterAlpha, TransparencyOffDrawsTheSceneWithoutItsBlendedPanels) {
  lod::LodAsset asset = test::bakeScene(alphaScene(false));
  ASSERT_FALSE(asset.dags.empty());
  Scene withoutBlend = lod::levelZeroScene(asset);
  withoutBlend.instances.resize(2); // the wall and the masked panel
  ImageRGBA8 fwd = forwardImage(context(), withoutBlend, alphaSettings(RasterBackend::Auto).base);
  auto renderer = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ClusterRenderSettings s = alphaSettings(RasterBackend::Auto);
  auto on = (*renderer)->render(s);
  s.transparency = false;
  auto off = (*renderer)->render(s);
  ASSERT_TRUE(on.ok() && off.ok());
  EXPECT_TRUE(hasPass(*on, "blend"));
  EXPECT_FALSE(hasPass(*off, "blend"));
  EXPECT_FALSE(hasPass(*off, "composite"));
  double pOff = psnr(fwd, off->image.srgb), pOn = psnr(fwd, on->image.srgb);
  std::printf("transparency off vs forward without the blended panels %.2f dB (on: %.2f dB)\n", pOff, pOn);
  EXPECT_GE(pOff, 35.0);
  EXPECT_LT(pOn, 30.0);
  writeOnFailure(off->image.srgb, "transparency_off.png");
}
