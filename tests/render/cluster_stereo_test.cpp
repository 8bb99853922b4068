// Stereo cluster rendering (docs/render.md, "Stereo"): one selection shared by both eyes, both eyes
// rasterized and resolved in one pass each into the halves of a side-by-side target. Each half must match a mono
// render of that eye's camera (the shared selection differs only where the nearer eye asks for a
// finer cut, well below the 45 dB bar), on every raster backend the device has and every selection.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "cluster_test_util.h"
#include "gpu_test.h"
#include "test_support.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "test_scenes.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kClusterStereoWidth = 80, kClusterStereoHeight = 64;

// A 3 x 3 grid of blobs: instances near the frustum sides, so that the two eyes see different
// instances (the union of the frusta matters) at different distances (so does the nearer eye).
const lod::LodAsset& gridAsset() {
  static lod::LodAsset asset = [] {
    lod::LodAsset a = test::smallBlobAsset();
    a.scene.instances.clear();
    for (int z = -1; z <= 1; ++z)
      for (int x = -1; x <= 1; ++x)
        a.scene.instances.push_back({0, glm::translate(glm::mat4(1.0f), {x * 3.0f, 0.0f, z * 3.0f})});
    return a;
  }();
  return asset;
}

// An n x n grid of quads in the XY plane at z facing +Z, uv 0..1 over it.
Mesh panel(float halfSize, float z, uint32_t material) {
  Mesh m;
  m.name = "panel";
  m.material = material;
  constexpr int n = 12;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      float u = float(x) / n, v = float(y) / n;
      m.positions.push_back({(u * 2.0f - 1.0f) * halfSize, (v * 2.0f - 1.0f) * halfSize, z});
      m.normals.push_back({0, 0, 1});
      m.uv0.push_back({u, 1.0f - v});
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + n + 2, d = a + n + 1;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

// A wall behind a checker-cut MASK panel and two BLEND panels in front (alpha tests and
// transparency lists per eye).
const lod::LodAsset& maskedBlendedAsset() {
  static lod::LodAsset asset = [] {
    Scene scene;
    scene.materials = {test::solidMaterial({0.25f, 0.6f, 0.3f, 1.0f}, AlphaMode::Opaque),
                       test::solidMaterial({0.9f, 0.2f, 0.2f, 1.0f}, AlphaMode::Mask, /*doubleSided=*/true),
                       test::solidMaterial({0.1f, 0.3f, 0.9f, 0.5f}, AlphaMode::Blend),
                       test::solidMaterial({0.9f, 0.8f, 0.1f, 0.4f}, AlphaMode::Blend)};
    scene.materials[1].alphaCutoff = 0.5f;
    scene.materials[1].baseColorTexture = 0;
    scene.textures.push_back(test::checkerCutout());
    scene.meshes = {panel(2.5f, -1.0f, 0), panel(1.2f, 0.0f, 1), panel(0.8f, 0.0f, 2), panel(0.8f, 0.0f, 3)};
    scene.instances = {{0, glm::mat4(1.0f)},
                       {1, glm::mat4(1.0f)},
                       {2, glm::translate(glm::mat4(1.0f), {-0.45f, 0.1f, 0.6f})},
                       {3, glm::translate(glm::mat4(1.0f), {0.45f, -0.1f, 1.1f})}};
    auto baked = lod::bakeLodAsset(scene, lod::BuildConfig{});
    EXPECT_TRUE(baked.ok()) << baked.error().message;
    return baked.ok() ? std::move(*baked) : lod::LodAsset{};
  }();
  return asset;
}

// Each half of a stereo render of `camera` against a mono render of that eye (PSNR >= 45 dB).
void expectHalvesMatchMono(ClusterRenderer& renderer, const ClusterRenderOutput& stereo,
                           const std::array<Camera, 2>& eyes, const ClusterRenderSettings& monoBase) {
  ASSERT_EQ(stereo.image.srgb.width, 2 * monoBase.base.width);
  for (uint32_t e = 0; e < 2; ++e) {
    ClusterRenderSettings s = monoBase;
    s.base.camera = eyes[e];
    s.stereoIpd.reset();
    auto mono = renderer.render(s);
    ASSERT_TRUE(mono.ok()) << mono.error().message;
    ImageRGBA8 h = test::stereoHalf(stereo.image.srgb, e);
    EXPECT_GE(psnr(h, mono->image.srgb), 45.0) << "eye " << e;
  }
}

ClusterRenderSettings stereoSettings(const Camera& camera, RasterBackend backend, SelectionMode selection) {
  ClusterRenderSettings s;
  s.selection = selection;
  s.base.width = kClusterStereoWidth;
  s.base.height = kClusterStereoHeight;
  s.base.camera = camera;
  s.base.background = {0.1f, 0.2f, 0.3f, 1.0f};
  s.raster = backend;
  return s;
}

} // namespace

TEST(StereoEyes, MovesEyeAndTargetAlongTheRightVector) {
  Camera c;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  auto eyes = stereoEyes(c, 0.064f);
  // Looking down -z with +y up, right is +x: left eye at -ipd/2, right at +ipd/2, axes parallel.
  EXPECT_NEAR(eyes[0].eye.x, -0.032f, 1e-7f);
  EXPECT_NEAR(eyes[1].eye.x, 0.032f, 1e-7f);
  EXPECT_EQ(eyes[0].eye.y, 0.0f);
  EXPECT_EQ(eyes[0].eye.z, 5.0f);
  EXPECT_EQ(eyes[0].target - eyes[0].eye, c.target - c.eye);
  EXPECT_EQ(eyes[1].target - eyes[1].eye, c.target - c.eye);
  EXPECT_EQ(eyes[1].fovYDegrees, c.fovYDegrees);
}

TEST(StereoEyes, IpdMustBeFiniteAndNonNegative) {
  EXPECT_TRUE(validateIpd(0.064f).ok());
  EXPECT_TRUE(validateIpd(0.0f).ok());
  for (float bad : {-0.01f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    Status st = validateIpd(bad);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("--ipd"), std::string::npos) << st.error().message;
  }
}

class ClusterStereo : public test::GpuTest {};

TEST_F(ClusterStereo, EachHalfMatchesAMonoRenderOfThatEye) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  Camera camera = autoCamera(bounds, float(kClusterStereoWidth) / kClusterStereoHeight);
  camera.eye = glm::mix(camera.target, camera.eye, 0.6f); // close: the grid's sides leave the frame
  // A wide baseline so that the eyes' images differ visibly (a real IPD on this small scene would not).
  float ipd = 0.15f * glm::length(bounds.max - bounds.min);
  auto eyes = stereoEyes(camera, ipd);
  // Every backend with the flat pass; the traversals (which cull and project per BVH node) on one.
  std::vector<std::pair<RasterBackend, SelectionMode>> runs;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) runs.emplace_back(backend, SelectionMode::Flat);
  runs.emplace_back(runs.back().first, SelectionMode::Hierarchy);
  runs.emplace_back(runs.back().first, SelectionMode::Dag);
  for (auto [backend, selection] : runs) {
    SCOPED_TRACE(std::string(toString(backend)) + " " + toString(selection));
    ClusterRenderSettings s = stereoSettings(camera, backend, selection);
    s.stereoIpd = ipd;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    ASSERT_EQ(stereo->image.srgb.width, 2 * kClusterStereoWidth);
    ASSERT_EQ(stereo->image.srgb.height, kClusterStereoHeight);
    ImageRGBA8 halves[2] = {test::stereoHalf(stereo->image.srgb, 0), test::stereoHalf(stereo->image.srgb, 1)};
    EXPECT_LT(psnr(halves[0], halves[1]), 30.0) << "the eyes see the same image";
    // Both eyes in one raster pass and one resolve pass.
    EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "raster"), 1);
    EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "resolve"), 1);
    uint64_t monoTriangles[2] = {};
    for (uint32_t e = 0; e < 2; ++e) {
      auto mono = (*renderer)->render(stereoSettings(eyes[e], backend, selection));
      ASSERT_TRUE(mono.ok()) << mono.error().message;
      monoTriangles[e] = mono->stats.trianglesRasterized;
      double db = psnr(halves[e], mono->image.srgb);
      EXPECT_GE(db, 45.0) << "eye " << e;
    }
    // One selection for both: it holds what either eye draws (union of frusta, finer of the cuts).
    EXPECT_GE(stereo->stats.trianglesRasterized, std::max(monoTriangles[0], monoTriangles[1]));
    EXPECT_LT(stereo->stats.trianglesRasterized, monoTriangles[0] + monoTriangles[1]);
  }
}

TEST_F(ClusterStereo, RefusesWhatTheSharedSelectionCannotServe) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ClusterRenderSettings s =
      stereoSettings(autoCamera((*renderer)->worldBounds(), 1.0f), RasterBackend::Auto, SelectionMode::Auto);
  s.stereoIpd = -1.0f;
  auto bad = (*renderer)->render(s);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--ipd"), std::string::npos);
  s.stereoIpd = 0.064f;
  s.occlusionCulling = true;
  s.readOwnedClusters = true;
  auto owned = (*renderer)->render(s);
  ASSERT_FALSE(owned.ok());
  EXPECT_NE(owned.error().message.find("--stereo"), std::string::npos);
}

// A cluster hidden from one eye but not the other must be drawn: a wall hides a small blob from
// the left eye while the right eye sees past the wall's edge. A first frame with the eyes together
// (the blob hidden from both: no history) makes the blob a pass-2 candidate in the second, which
// the HZB test must keep for the right eye.
TEST_F(ClusterStereo, OcclusionKeepsWhatOnlyOneEyeSees) {
  gpu::Context& ctx = context();
  io::BlobOptions o;
  o.subdivisions = 3;
  o.radius = 0.3f;
  Scene scene = io::generateBlob(o);
  scene.materials.push_back(test::solidMaterial({0.8f, 0.8f, 0.8f, 1.0f}, AlphaMode::Opaque));
  scene.meshes.push_back(panel(2.0f, 0.0f, uint32_t(scene.materials.size() - 1)));
  scene.instances = {{0, glm::translate(glm::mat4(1.0f), {3.2f, 0.0f, -4.0f})},
                     {uint32_t(scene.meshes.size() - 1), glm::mat4(1.0f)}};
  auto baked = lod::bakeLodAsset(scene, lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  Camera camera;
  camera.eye = {0.0f, 0.0f, 4.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    SCOPED_TRACE(toString(backend));
    auto renderer = ClusterRenderer::create(ctx, *baked);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    ClusterRenderSettings s = stereoSettings(camera, backend, SelectionMode::Flat);
    s.base.width = 256;
    s.base.height = 192;
    s.occlusionCulling = true;
    s.stereoIpd = 0.01f;
    ASSERT_TRUE((*renderer)->render(s).ok());
    s.stereoIpd = 3.0f;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    ClusterRenderSettings mono = s;
    mono.occlusionCulling = false;
    expectHalvesMatchMono(**renderer, *stereo, stereoEyes(camera, 3.0f), mono);
  }
}

// Occlusion culling in stereo: one HZB over both eyes, a cluster culled only when hidden from both,
// the history the union of what either eye showed. Over frames (the second one draws pass 1 from
// the first's history) each half still equals a mono render of its eye without occlusion.
TEST_F(ClusterStereo, OcclusionCullingKeepsEachEyeImage) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  // Low over the grid's front row: the rows behind are partly hidden.
  Camera camera;
  camera.target = bounds.center() + glm::vec3(0.0f, 0.0f, -3.0f);
  camera.eye = bounds.center() + glm::vec3(0.3f, 0.2f, 6.0f);
  float ipd = 0.6f;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    SCOPED_TRACE(toString(backend));
    ClusterRenderSettings s = stereoSettings(camera, backend, SelectionMode::Flat);
    s.occlusionCulling = true;
    s.stereoIpd = ipd;
    for (int frame = 0; frame < 2; ++frame) {
      auto stereo = (*renderer)->render(s);
      ASSERT_TRUE(stereo.ok()) << stereo.error().message;
      EXPECT_TRUE(stereo->stats.occlusion);
      ClusterRenderSettings mono = s;
      mono.occlusionCulling = false;
      expectHalvesMatchMono(**renderer, *stereo, stereoEyes(camera, ipd), mono);
    }
  }
}

// The compute raster draws the right eye from the left eye's clip positions (x shifted): triangles
// crossing the near plane must still be clipped per eye as a mono render of that eye clips them.
TEST_F(ClusterStereo, NearPlaneCrossingTrianglesMatchPerEye) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  // Just in front of the middle blob, the near plane cutting through its front, the others in view behind.
  Camera camera;
  camera.target = bounds.center() + glm::vec3(0.0f, 0.0f, -10.0f);
  camera.eye = bounds.center() + glm::vec3(0.2f, 0.1f, 1.4f);
  camera.znear = 0.4f;
  camera.zfar = 20.0f;
  float ipd = 0.3f;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) {
    SCOPED_TRACE(toString(backend));
    ClusterRenderSettings s = stereoSettings(camera, backend, SelectionMode::Flat);
    s.stereoIpd = ipd;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    if (backend == RasterBackend::Compute) {
      EXPECT_GT(stereo->stats.trianglesNearClipped, 0u);
    }
    expectHalvesMatchMono(**renderer, *stereo, stereoEyes(camera, ipd), s);
  }
}

// Alpha MASK and BLEND: every rasterizer alpha-tests each eye's pixels with that eye's camera (the
// compute raster's right-eye threads, the hardware draws in the right half), so the cut-outs of a
// checker panel in front of a wall land where a mono render of each eye puts them; the blended
// panels in front go through per-eye transparency lists (each blend raster) and one composite.
TEST_F(ClusterStereo, MaskedAndBlendedMatchPerEye) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, maskedBlendedAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  Camera camera;
  camera.eye = {0.3f, 0.4f, 4.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  float ipd = 0.5f; // a checker cell shifts visibly between the eyes
  std::vector<BlendRaster> blends{BlendRaster::Compute};
  if (ctx.caps().fragmentStoresAndAtomics) blends.insert(blends.end(), {BlendRaster::Hybrid, BlendRaster::Hardware});
  std::vector<std::pair<RasterBackend, BlendRaster>> runs;
  for (RasterBackend backend : test::availableRasterBackends(ctx)) runs.emplace_back(backend, BlendRaster::Compute);
  for (BlendRaster blend : blends) runs.emplace_back(test::availableRasterBackends(ctx).back(), blend);
  runs.emplace_back(RasterBackend::Indirect, BlendRaster::Hardware);
  for (auto [backend, blend] : runs) {
    SCOPED_TRACE(std::string(toString(backend)) + " blend " + toString(blend));
    ClusterRenderSettings s = stereoSettings(camera, backend, SelectionMode::Flat);
    s.tauPixels = 0.5f;
    s.blendRaster = blend;
    s.stereoIpd = ipd;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    EXPECT_LT(psnr(test::stereoHalf(stereo->image.srgb, 0), test::stereoHalf(stereo->image.srgb, 1)), 30.0);
    expectHalvesMatchMono(**renderer, *stereo, stereoEyes(camera, ipd), s);
  }
}

// Stereo by multiview (the hardware rasters: view mask 0b11 into 2-layer targets, copied side by
// side; hybrid's fragments into the side-by-side buffer) against per-eye viewports: the same image, each half a mono
// render of its eye, with occlusion culling over two frames (pass 1 loads pass 0's layers) and with MASK and BLEND
// materials (the fragment shaders' eye frame and side-by-side pixel come from gl_ViewIndex).
TEST_F(ClusterStereo, MultiviewMatchesViewportsAndEachEye) {
  gpu::Context& ctx = context();
  std::vector<RasterBackend> backends{RasterBackend::Indirect};
  if (ctx.caps().multiviewMeshShader) backends.push_back(RasterBackend::Mesh);
  if (ctx.caps().int64BufferAtomics &&
      ctx.caps().fragmentStoresAndAtomics) // its list: indirect without multiviewMeshShader
    backends.push_back(RasterBackend::Hybrid);
  if (!ctx.caps().multiview) GTEST_SKIP() << "the device has no multiview";
  if (!ctx.caps().multiviewMeshShader)
    std::printf("note: the device has no multiviewMeshShader: the mesh raster is not tested by multiview here\n");
  struct Case {
    const lod::LodAsset* asset;
    Camera camera;
    float ipd;
    bool occlusion;
  };
  Camera grid;
  grid.target = {0.0f, 0.0f, -3.0f};
  grid.eye = {0.3f, 0.4f, 6.0f};
  Camera panels;
  panels.eye = {0.3f, 0.4f, 4.0f};
  panels.target = {0.0f, 0.0f, 0.0f};
  const Case cases[] = {{&gridAsset(), grid, 1.2f, false},
                        {&gridAsset(), grid, 1.2f, true},
                        {&maskedBlendedAsset(), panels, 0.5f, false}};
  for (const Case& c : cases)
    for (RasterBackend backend : backends) {
      SCOPED_TRACE(std::string(toString(backend)) + (c.occlusion ? " occlusion" : "") +
                   (c.asset == &gridAsset() ? " grid" : " masked+blended"));
      auto renderer = ClusterRenderer::create(ctx, *c.asset);
      ASSERT_TRUE(renderer.ok()) << renderer.error().message;
      ClusterRenderSettings s = stereoSettings(c.camera, backend, SelectionMode::Flat);
      s.stereoIpd = c.ipd;
      s.occlusionCulling = c.occlusion;
      s.blendRaster = ctx.caps().fragmentStoresAndAtomics ? BlendRaster::Hardware : BlendRaster::Compute;
      s.hybridThreshold = 0.0f; // hybrid: every cluster through the hardware list
      ClusterRenderOutput out[2];
      for (int frame = 0; frame < (c.occlusion ? 2 : 1); ++frame) // frame 2: pass 1 draws from the history
        for (StereoMode mode : {StereoMode::Multiview, StereoMode::Viewports}) {
          s.stereoMode = mode;
          auto r = (*renderer)->render(s);
          ASSERT_TRUE(r.ok()) << r.error().message;
          EXPECT_EQ(r->stats.stereoMode, mode);
          out[mode == StereoMode::Viewports] = std::move(*r);
        }
      if (backend == RasterBackend::Hybrid) {
        EXPECT_GT(out[0].stats.clustersHardware, 0u);
      }
      const ImageRGBA8& multiview = out[0].image.srgb;
      EXPECT_GE(psnr(multiview, out[1].image.srgb), 45.0) << "multiview against per-eye viewports";
      // An eye index ignored would draw the left eye into both layers.
      EXPECT_LT(psnr(test::stereoHalf(multiview, 0), test::stereoHalf(multiview, 1)), 30.0)
          << "the eyes see the same image";
      // The image backends copy the layers side by side once per pass; hybrid's fragments write the buffer.
      EXPECT_EQ(test::passCount(out[0].image.stats.passTimes, "layer-copy"), backend == RasterBackend::Hybrid ? 0
                                                                             : c.occlusion                    ? 2
                                                                                                              : 1);
      // Plausible pass times: lavapipe can resolve the copy's begin timestamp after its end, which
      // must not wrap around to ~1.8e13 ms.
      for (const auto& t : out[0].image.stats.passTimes) EXPECT_LT(t.milliseconds, 1e6) << t.name;
      EXPECT_EQ(out[0].stats.trianglesRasterized, out[1].stats.trianglesRasterized);
      ClusterRenderSettings mono = s;
      mono.occlusionCulling = false;
      expectHalvesMatchMono(**renderer, out[0], stereoEyes(c.camera, c.ipd), mono);
    }
}

// Multiview is asked for where it cannot run: a clear error naming the option; auto is per-eye
// viewports (measured faster), and a mono frame reports no stereo mode.
TEST_F(ClusterStereo, MultiviewRefusedWhereItCannotRun) {
  gpu::Context& ctx = context();
  auto renderer = ClusterRenderer::create(ctx, gridAsset());
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  ClusterRenderSettings s =
      stereoSettings(autoCamera((*renderer)->worldBounds(), 1.0f), RasterBackend::Indirect, SelectionMode::Flat);
  auto mono = (*renderer)->render(s);
  ASSERT_TRUE(mono.ok()) << mono.error().message;
  EXPECT_EQ(mono->stats.stereoMode, StereoMode::Auto);
  s.stereoIpd = 0.2f;
  auto stereo = (*renderer)->render(s);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  EXPECT_EQ(stereo->stats.stereoMode, StereoMode::Viewports);
  std::vector<RasterBackend> refused;
  if (ctx.caps().int64BufferAtomics) refused.push_back(RasterBackend::Compute);
  if (ctx.caps().meshShader && !ctx.caps().multiviewMeshShader) refused.push_back(RasterBackend::Mesh);
  // Hybrid under auto: per-eye viewports too.
  if (ctx.caps().int64BufferAtomics && ctx.caps().fragmentStoresAndAtomics && ctx.caps().meshShader) {
    s.raster = RasterBackend::Hybrid;
    auto hybrid = (*renderer)->render(s);
    ASSERT_TRUE(hybrid.ok()) << hybrid.error().message;
    EXPECT_EQ(hybrid->stats.stereoMode, StereoMode::Viewports);
  }
  for (RasterBackend backend : refused) {
    SCOPED_TRACE(toString(backend));
    s.raster = backend;
    s.stereoMode = StereoMode::Auto;
    auto fallback = (*renderer)->render(s);
    ASSERT_TRUE(fallback.ok()) << fallback.error().message;
    EXPECT_EQ(fallback->stats.stereoMode, StereoMode::Viewports);
    s.stereoMode = StereoMode::Multiview;
    auto bad = (*renderer)->render(s);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("--stereo-mode multiview"), std::string::npos) << bad.error().message;
  }
}
