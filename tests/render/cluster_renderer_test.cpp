// Cluster-LOD renderer on small baked assets (lavapipe-sized): GPU selection against a CPU
// LOCALCUT reference, backends agreeing with each other, LOD vs a full-resolution forward render,
// no cracks at any threshold, fewer triangles at larger thresholds. Validation must stay silent.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>

#include "gpu_test.h"
#include "mirage/core/color.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/io/image_io.h"
#include "mirage/io/import.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "render/cluster_test_util.h"
#include "mirage/shaderio/lod_error.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::availableRasterBackends;
using mirage::test::kClusterTestSize;
using mirage::test::renderCluster;

using mirage::test::blobAsset;
using mirage::test::defaultBlobAsset;
using mirage::test::settingsFor;
using mirage::test::writeOnFailure;

class ClusterRender : public test::GpuTest {};

// LOCALCUT on the CPU with the renderer's projection (identity instance transform): clusters and
// triangles on the cut, and how many group spheres hold the eye (projected as +infinity).
struct CpuCut {
  uint32_t clusters = 0;
  uint64_t triangles = 0;
  uint32_t eyeInside = 0;
};
CpuCut cpuCut(const lod::ClusterDag& dag, const Camera& cam, float tau) {
  float pixelScale = shaderio::projectionScale(cam.projection(1.0f)[1][1], float(kClusterTestSize));
  CpuCut cut;
  auto projected = [&](const lod::LodBounds& b, bool root) {
    if (root) return std::numeric_limits<float>::infinity();
    float e = shaderio::projectedSphereError(b.center, b.radius, b.error, 1.0f, cam.eye, cam.znear, pixelScale);
    if (std::isinf(e)) ++cut.eyeInside; // finite error, eye inside the sphere
    return e;
  };
  for (const lod::Cluster& c : dag.clusters)
    if (projected(c.self, false) <= tau && projected(c.parent, c.group == lod::kNone) > tau)
      ++cut.clusters, cut.triangles += c.triangleCount;
  return cut;
}

void expectSelectionMatchesCpu(gpu::Context& ctx, const Camera& camera, float tau, bool expectEyeInside,
                               SelectionMode mode) {
  SCOPED_TRACE(toString(mode));
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(ctx, asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), tau, RasterBackend::Indirect);
  s.selection = mode;
  s.base.camera = camera;
  s.frustumCulling = false;
  s.occlusionCulling = false; // the whole cut is drawn: compare it with the CPU's
  s.coneCulling = false;
  auto out = (*r)->render(s);
  ASSERT_TRUE(out.ok()) << out.error().message;
  const lod::ClusterDag& dag = asset.dags[0];
  CpuCut cut = cpuCut(dag, withClipPlanes(camera, (*r)->worldBounds()), tau);
  // The cull pass skips levels that cannot be on this instance's cut: from outside every LOD sphere
  // fewer clusters are tested; with the eye inside one, every cluster is (flat pass); the BVH
  // traversal tests the clusters of groups above the cut (here close to all of them at small tau).
  if (mode != SelectionMode::Flat)
    EXPECT_LE(out->stats.clustersTested, dag.clusters.size());
  else if (expectEyeInside)
    EXPECT_EQ(out->stats.clustersTested, dag.clusters.size());
  else
    EXPECT_LT(out->stats.clustersTested, dag.clusters.size());
  EXPECT_EQ(out->stats.instancesVisible, 1u);
  EXPECT_EQ(out->stats.clustersSelected, cut.clusters);
  EXPECT_EQ(out->stats.trianglesRasterized, cut.triangles);
  EXPECT_EQ(out->stats.clustersOverflow, 0u);
  EXPECT_EQ(cut.eyeInside > 0, expectEyeInside);
}

// Instances translated along the view axis, near to far: the per-instance level ranges of the cull
// pass must not change what LOCALCUT selects (a translated instance's cut is the identity cut seen
// from the eye minus the offset).
TEST_F(ClusterRender, LevelPruningKeepsTheCutForManyInstances) {
  lod::LodAsset asset = blobAsset();
  Bounds b = asset.scene.worldBounds();
  Camera cam = autoCamera(b, 1.0f);
  glm::vec3 away = glm::normalize(cam.target - cam.eye);
  std::vector<glm::vec3> offsets;
  for (float k : {0.0f, 1.5f, 4.0f, 10.0f, 30.0f, 100.0f}) offsets.push_back(away * (k * b.radius()));
  asset.scene.instances.clear();
  for (const glm::vec3& o : offsets) asset.scene.instances.push_back({0, glm::translate(glm::mat4(1.0f), o)});
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor(b, 1.0f, RasterBackend::Indirect);
  cam.zfar = glm::length(cam.eye - cam.target) + 120.0f * b.radius();
  cam.znear = 0.01f * b.radius();
  s.base.camera = cam;
  s.frustumCulling = false;
  s.occlusionCulling = false;
  s.coneCulling = false;
  for (SelectionMode mode : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag}) {
    SCOPED_TRACE(toString(mode));
    s.selection = mode;
    auto out = (*r)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    uint32_t clusters = 0;
    uint64_t triangles = 0;
    for (const glm::vec3& o : offsets) {
      Camera shifted = cam;
      shifted.eye -= o;
      shifted.target -= o;
      CpuCut cut = cpuCut(asset.dags[0], shifted, 1.0f);
      clusters += cut.clusters;
      triangles += cut.triangles;
    }
    EXPECT_EQ(out->stats.instancesVisible, offsets.size());
    EXPECT_EQ(out->stats.clustersSelected, clusters);
    EXPECT_EQ(out->stats.trianglesRasterized, triangles);
    EXPECT_LT(out->stats.clustersTested, uint64_t(asset.dags[0].clusters.size()) * offsets.size() / 2);
    EXPECT_EQ(out->stats.clustersOverflow, 0u);
  }
}

// The BVH traversal and the DAG group-tree traversal select exactly what the flat pass selects,
// with every culling option on, at several thresholds and cameras (far, close up, inside group
// spheres, partly out of view), over two frames (the second with occlusion history): same counts,
// same triangles, the same pixels.
TEST_F(ClusterRender, HierarchicalSelectionMatchesFlat) {
  const lod::LodAsset& asset = blobAsset();
  auto flat = ClusterRenderer::create(context(), asset);
  auto tree = ClusterRenderer::create(context(), asset);
  auto dagTree = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(flat.ok() && tree.ok() && dagTree.ok());
  Camera far = autoCamera((*flat)->worldBounds(), 1.0f);
  Camera close = far;
  close.eye = glm::mix(far.target, far.eye, 0.45f); // the blob fills the view, partly outside it
  close.znear = 0.01f;
  Camera inside; // just above the surface, looking along it: inside group spheres
  inside.eye = {0.0f, 0.0f, 1.3f};
  inside.target = {1.0f, 0.2f, 1.3f};
  inside.znear = 0.01f;
  inside.zfar = 10.0f;
  uint32_t fewerTested[2] = {0, 0};
  for (const Camera& cam : {far, close, inside})
    for (float tau : {0.5f, 1.0f, 3.0f, 12.0f}) {
      SCOPED_TRACE(fmt::format("eye {} {} {}, tau {}", cam.eye.x, cam.eye.y, cam.eye.z, tau));
      ClusterRenderSettings s = settingsFor((*flat)->worldBounds(), tau, RasterBackend::Auto);
      s.base.camera = cam;
      for (int frame = 0; frame < 2; ++frame) {
        // Frame 0 without occlusion: the whole cut is drawn and compared; frame 1 with the history
        // of frame 0 (which cluster owns a pixel where two tie can differ, so only the selection
        // counts and the image are compared there).
        s.occlusionCulling = frame == 1;
        s.selection = SelectionMode::Flat;
        auto a = (*flat)->render(s);
        ASSERT_TRUE(a.ok());
        for (int t = 0; t < 2; ++t) {
          s.selection = t == 0 ? SelectionMode::Hierarchy : SelectionMode::Dag;
          SCOPED_TRACE(toString(s.selection));
          auto b = (t == 0 ? *tree : *dagTree)->render(s);
          ASSERT_TRUE(b.ok());
          EXPECT_EQ(b->stats.selection, s.selection);
          EXPECT_EQ(a->stats.clustersSelected, b->stats.clustersSelected);
          EXPECT_EQ(a->stats.clustersBackfaceCulled, b->stats.clustersBackfaceCulled);
          if (frame == 0) {
            EXPECT_EQ(a->stats.clustersDrawn, b->stats.clustersDrawn);
            EXPECT_EQ(a->stats.trianglesRasterized, b->stats.trianglesRasterized);
          }
          EXPECT_EQ(b->stats.clustersOverflow, 0u);
          EXPECT_GT(b->stats.nodesTested, 0u);
          EXPECT_GT(b->stats.clustersSelected, 0u);
          EXPECT_GE(psnr(a->image.srgb, b->image.srgb), 60.0); // identical but for ties between equal depths
          fewerTested[t] += b->stats.clustersTested < a->stats.clustersTested;
        }
      }
    }
  // Of 24 renders: the traversals skip groups below the cut.
  EXPECT_GT(fewerTested[0], 12u);
  EXPECT_GT(fewerTested[1], 12u);
}

TEST_F(ClusterRender, SelectionMatchesCpuLocalCut) {
  Camera cam = autoCamera(blobAsset().scene.worldBounds(), 1.0f);
  for (SelectionMode mode : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag})
    expectSelectionMatchesCpu(context(), cam, 2.0f, /*expectEyeInside=*/false, mode);
  EXPECT_LT(cpuCut(blobAsset().dags[0], cam, 2.0f).triangles, blobAsset().dags[0].inputTriangles);
}

// A camera inside group spheres (just above the surface): those project to +infinity and refine.
TEST_F(ClusterRender, SelectionMatchesCpuWithEyeInsideSpheres) {
  Camera cam;
  cam.eye = {0.0f, 0.0f, 1.3f};
  cam.target = {1.0f, 0.0f, 1.3f};
  cam.znear = 0.01f;
  cam.zfar = 10.0f;
  for (SelectionMode mode : {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag})
    for (float tau : {0.5f, 1.0f, 4.0f}) expectSelectionMatchesCpu(context(), cam, tau, /*expectEyeInside=*/true, mode);
}

// At full resolution (tiny tau) the LOD renderer must reproduce the forward renderer of the
// source mesh on every backend; at a quarter pixel (when minPsnrQuarterPixel > 0) the cut is
// coarser but must still look the same (PSNR).
void expectMatchesForward(gpu::Context& ctx, const lod::LodAsset& asset, const char* name, double minPsnrQuarterPixel) {
  Scene reference = lod::levelZeroScene(asset);
  auto fwd = ForwardRenderer::create(ctx, reference);
  ASSERT_TRUE(fwd.ok());
  ClusterRenderSettings s = settingsFor(reference.worldBounds(), 0.25f, RasterBackend::Auto);
  auto a = (*fwd)->render(s.base);
  ASSERT_TRUE(a.ok());
  for (RasterBackend b : availableRasterBackends(ctx)) {
    s.raster = b;
    for (float tau : {0.001f, 0.25f}) {
      if (tau > 0.01f && minPsnrQuarterPixel <= 0.0) continue;
      s.tauPixels = tau;
      ClusterRenderOutput lodOut = renderCluster(ctx, asset, s);
      double p = psnr(a->srgb, lodOut.image.srgb);
      std::printf("%s %s tau %g: %llu triangles, PSNR %.2f dB\n", name, toString(b), tau,
                  (unsigned long long)lodOut.stats.trianglesRasterized, p);
      EXPECT_GE(p, tau < 0.01f ? 60.0 : minPsnrQuarterPixel) << name << " " << toString(b) << " tau " << tau;
      writeOnFailure(lodOut.image.srgb, std::string(name) + "_lod_" + toString(b) + ".png");
    }
  }
  writeOnFailure(a->srgb, std::string(name) + "_forward.png");
}

TEST_F(ClusterRender, SmallTauMatchesForwardOnBlob) { expectMatchesForward(context(), blobAsset(), "blob", 40.0); }

// Box filter over factor x factor pixels, averaged in linear light: the anti-aliased image a
// viewer sees of a supersampled render.
ImageRGBA8 downsampleLinear(const ImageRGBA8& image, uint32_t factor) {
  ImageRGBA8 out;
  out.width = image.width / factor;
  out.height = image.height / factor;
  out.pixels.resize(size_t(out.width) * out.height * 4);
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x)
      for (uint32_t c = 0; c < 4; ++c) {
        float sum = 0.0f;
        for (uint32_t dy = 0; dy < factor; ++dy)
          for (uint32_t dx = 0; dx < factor; ++dx) {
            uint8_t v = image.at(x * factor + dx, y * factor + dy)[c];
            sum += c == 3 ? float(v) / 255.0f : srgb8ToLinear(v);
          }
        float mean = sum / float(factor * factor);
        out.at(x, y)[c] = c == 3 ? uint8_t(std::lround(mean * 255.0f)) : linearToSrgb8(mean);
      }
  return out;
}

// 40 dB at a quarter pixel on the bunny and the dragon, judged on the image a viewer sees: both
// renders at 4x4 samples per pixel (1024x1024, tau 1 sample = 0.25 output pixel), box-filtered to
// 256x256, with the default build, whose error is shading-aware (BuildConfig::normalWeight): the
// geometric error alone does not bound shading (the bunny spread 39.7-42.8 dB over equally good
// DAGs, the dragon gave 36.8 dB). With the default the dragon draws 341 k of 871 k triangles at
// 49.3 dB. Returns the PSNR.
double expectSupersampledQuarterPixel(gpu::Context& ctx, const Scene& scene, const lod::LodAsset& asset,
                                      const char* name, double maxTriangleFraction) {
  constexpr uint32_t kSamples = 4;
  auto fwd = ForwardRenderer::create(ctx, scene);
  EXPECT_TRUE(fwd.ok());
  if (!fwd.ok()) return 0.0;
  ClusterRenderSettings s = settingsFor(scene.worldBounds(), 1.0f, RasterBackend::Compute);
  s.base.width = s.base.height = kClusterTestSize * kSamples;
  auto a = (*fwd)->render(s.base);
  EXPECT_TRUE(a.ok());
  if (!a.ok()) return 0.0;
  ImageRGBA8 reference = downsampleLinear(a->srgb, kSamples);
  ClusterRenderOutput lodOut = renderCluster(ctx, asset, s);
  ImageRGBA8 lod = downsampleLinear(lodOut.image.srgb, kSamples);
  double p = psnr(reference, lod);
  std::printf("%s tau 0.25 output px: %llu of %u triangles, PSNR %.2f dB\n", name,
              (unsigned long long)lodOut.stats.trianglesRasterized, (unsigned)scene.instancedTriangleCount(), p);
  EXPECT_GE(p, 40.0) << name;
  // A cut much finer than needed would pass trivially: the quarter-pixel cut must be a real LOD
  // where the input's triangles are smaller than a sample.
  EXPECT_LE(double(lodOut.stats.trianglesRasterized), maxTriangleFraction * scene.instancedTriangleCount()) << name;
  if (p < 40.0) {
    writeOnFailure(reference, std::string(name) + "_forward_ss.png");
    writeOnFailure(lod, std::string(name) + "_lod_ss.png");
  }
  return p;
}

// The build the quarter-pixel tests judge: the default one, whose error is shading-aware.
Result<lod::LodAsset> bakeShadingAware(const Scene& scene) { return lod::bakeLodAsset(scene, lod::BuildConfig{}); }

TEST_F(ClusterRender, QuarterPixelTauMatchesSupersampledForwardOnBunny) {
  MIRAGE_REQUIRE_DATA(path, "stanford-bunny/bun_zipper.ply");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto asset = bakeShadingAware(*scene);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  expectMatchesForward(context(), *asset, "bunny", 0.0); // tiny tau on every backend
  // The bunny's triangles cover about 4x4 samples here, so the shading-aware error keeps all the
  // visible ones (50 k of 69 k; the geometric error alone drew 15 k at 42.8 dB).
  expectSupersampledQuarterPixel(context(), *scene, *asset, "bunny", 1.0);
}

TEST_F(ClusterRender, QuarterPixelTauMatchesSupersampledForwardOnDragon) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto asset = bakeShadingAware(*scene);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  expectSupersampledQuarterPixel(context(), *scene, *asset, "dragon", 0.5);
}

// Single-sample PSNR of the default build at the default tau against the forward render of the
// full mesh, one view (camera as `mirage render --camera`). Returns the PSNR; `drawn` receives the
// triangles rasterized.
double defaultCutPsnr(gpu::Context& ctx, const Scene& scene, const char* camera, uint32_t width, uint32_t height,
                      uint64_t& drawn) {
  auto asset = lod::bakeLodAsset(scene, lod::BuildConfig{});
  EXPECT_TRUE(asset.ok());
  auto cam = parseCamera(camera);
  EXPECT_TRUE(cam.ok());
  auto fwd = ForwardRenderer::create(ctx, scene);
  EXPECT_TRUE(fwd.ok());
  if (!asset.ok() || !cam.ok() || !fwd.ok()) return 0.0;
  ClusterRenderSettings s;
  s.base.width = width, s.base.height = height;
  s.base.camera = *cam;
  auto reference = (*fwd)->render(s.base);
  EXPECT_TRUE(reference.ok());
  if (!reference.ok()) return 0.0;
  ClusterRenderOutput lodOut = renderCluster(ctx, *asset, s);
  drawn = lodOut.stats.trianglesRasterized;
  double p = psnr(reference->srgb, lodOut.image.srgb);
  std::printf("%s: default build, tau %g px, %ux%u single-sample: %llu of %u triangles, PSNR %.2f dB\n", camera,
              s.tauPixels, width, height, (unsigned long long)drawn, (unsigned)scene.instancedTriangleCount(), p);
  if (p < 40.0) {
    writeOnFailure(reference->srgb, "closeview_forward.png");
    writeOnFailure(lodOut.image.srgb, "closeview_lod.png");
  }
  return p;
}

// The close view of the dragon (960x540; the input's triangles are ~2 px there): at the
// default settings a single-sample image within 40 dB of the full mesh's. With the geometric error
// alone this view gave 32.0 dB with 24 k triangles; the shading-aware default keeps the shading.
TEST_F(ClusterRender, DefaultsMatchForwardSingleSampleOnDragonCloseView) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  uint64_t drawn = 0;
  double p = defaultCutPsnr(context(), *scene, "eye=0.15,0.17,0.25,target=-0.006,0.125,-0.005,fov=45", 960, 540, drawn);
  EXPECT_GE(p, 40.0);
  EXPECT_LT(drawn, scene->instancedTriangleCount() / 2); // still a real LOD cut
}

// A glTF with normal maps (Khronos DamagedHelmet, 15 k triangles, ~1 px each at this size): the
// geometric error alone gave 29.7 dB (1.9 k triangles); the shading-aware default keeps it within
// 40 dB single-sample.
TEST_F(ClusterRender, DefaultsMatchForwardSingleSampleOnNormalMappedGltf) {
  MIRAGE_REQUIRE_DATA(path, "khronos-damaged-helmet/DamagedHelmet.glb");
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  uint64_t drawn = 0;
  EXPECT_GE(defaultCutPsnr(context(), *scene, "eye=2.2,1.0,4.8,target=0,0,0,fov=45", 320, 180, drawn), 40.0);
}

// A closed mesh with back faces kept and flagged magenta: any crack or overlap gap between
// clusters of different levels would let a back face show through.
void expectNoCracks(gpu::Context& ctx, const lod::LodAsset& asset) {
  auto r = ClusterRenderer::create(ctx, asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (RasterBackend b : availableRasterBackends(ctx)) {
    for (float tau : {0.5f, 2.0f, 6.0f, 20.0f}) {
      ClusterRenderSettings s = settingsFor((*r)->worldBounds(), tau, b);
      s.flagBackFaces = true;
      s.base.background = {0.0f, 1.0f, 0.0f, 1.0f}; // contrasting background
      auto out = (*r)->render(s);
      ASSERT_TRUE(out.ok()) << out.error().message;
      const ImageRGBA8& img = out->image.srgb;
      // A crack lets a back face show through the interior. On the outline, a pixel centre exactly on
      // a folded silhouette edge may go to the back triangle by the rasterizer's tie rule (the two
      // triangles have opposite screen winding): that is not a crack, so flagged pixels touching the
      // background are reported but not failed.
      auto isBackground = [&](int x, int y) {
        x = std::clamp(x, 0, int(img.width) - 1), y = std::clamp(y, 0, int(img.height) - 1);
        const uint8_t* q = img.at(uint32_t(x), uint32_t(y));
        return q[0] == 0 && q[1] == 255 && q[2] == 0;
      };
      size_t interiorFlagged = 0, silhouetteFlagged = 0, covered = 0;
      for (uint32_t y = 0; y < img.height; ++y)
        for (uint32_t x = 0; x < img.width; ++x) {
          const uint8_t* p = img.at(x, y);
          covered += !isBackground(int(x), int(y));
          if (!(p[0] == 255 && p[1] == 0 && p[2] == 255)) continue;
          bool touchesBackground = false;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) touchesBackground |= isBackground(int(x) + dx, int(y) + dy);
          (touchesBackground ? silhouetteFlagged : interiorFlagged)++;
        }
      EXPECT_EQ(interiorFlagged, 0u) << toString(b) << " tau " << tau;
      EXPECT_LE(silhouetteFlagged, 4u) << toString(b) << " tau " << tau;
      EXPECT_GT(covered, img.pixels.size() / 4 / 10) << toString(b) << " tau " << tau;
      writeOnFailure(img, std::string("cracks_") + toString(b) + ".png");
    }
  }
}

// On the geometric and on the default (shading-aware) build.
TEST_F(ClusterRender, NoCracksAtAnyTau) {
  for (const lod::LodAsset* asset : {&blobAsset(), &defaultBlobAsset()}) expectNoCracks(context(), *asset);
}

TEST_F(ClusterRender, LargerTauDrawsFewerTriangles) {
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  uint64_t previous = std::numeric_limits<uint64_t>::max(), first = 0, last = 0;
  for (float tau : {0.125f, 0.5f, 1.0f, 4.0f, 16.0f, 64.0f}) {
    ClusterRenderSettings s = settingsFor((*r)->worldBounds(), tau, RasterBackend::Indirect);
    s.occlusionCulling = false; // count the whole cut
    s.coneCulling = false;
    auto out = (*r)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    uint64_t t = out->stats.trianglesRasterized;
    EXPECT_LE(t, previous) << "tau " << tau;
    if (first == 0) first = t;
    last = t;
    previous = t;
  }
  EXPECT_EQ(first, blobAsset().dags[0].inputTriangles); // a tiny tau draws level 0
  EXPECT_LT(last * 4, first);
}

// A camera inside the mesh's bounding spheres (close to the surface): those spheres project to an
// unbounded error, so the nearby clusters refine to level 0 instead of failing or going coarse.
TEST_F(ClusterRender, CameraInsideBoundsRefines) {
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 1.0f, RasterBackend::Auto);
  s.base.camera.eye = {0.0f, 0.0f, 1.4f}; // just above the surface, looking along it
  s.base.camera.target = {1.0f, 0.0f, 1.4f};
  s.base.camera.znear = 0.01f;
  s.base.camera.zfar = 10.0f;
  auto out = (*r)->render(s);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_GT(out->stats.clustersSelected, 0u);
  EXPECT_GT(out->stats.clustersFrustumCulled, 0u); // the far side is out of view
}

TEST(ClusterRenderOptions, ParsesBackends) {
  EXPECT_EQ(*parseRasterBackend("mesh"), RasterBackend::Mesh);
  EXPECT_EQ(*parseRasterBackend("compute"), RasterBackend::Compute);
  EXPECT_EQ(*parseRasterBackend("hybrid"), RasterBackend::Hybrid);
  EXPECT_FALSE(parseRasterBackend("software").ok());
}

namespace {

// A wall of blob instances (scaled into a big occluder) in front of a grid of small blobs that it
// hides from the front view: occlusion culling must draw far fewer triangles there.
lod::LodAsset occluderScene() {
  lod::LodAsset asset = blobAsset();
  asset.scene.instances.clear();
  asset.scene.instances.push_back({0, glm::scale(glm::translate(glm::mat4(1.0f), {0, 0, 0}), glm::vec3(5.0f))});
  for (int gy = 0; gy < 12; ++gy)
    for (int gx = 0; gx < 12; ++gx) {
      glm::mat4 m = glm::translate(glm::mat4(1.0f), {(gx - 5.5f) * 0.45f, (gy - 5.5f) * 0.45f, -8.0f});
      asset.scene.instances.push_back({0, glm::scale(m, glm::vec3(0.4f))});
    }
  return asset;
}

} // namespace

// Two-pass occlusion over a camera path with a cut: every frame's image equals the image without
// occlusion culling; the first frame (no history) draws everything; frames that keep the view draw
// fewer triangles; after the cut the history is wrong and the image is still right.
TEST_F(ClusterRender, OcclusionCullingKeepsTheImageOverACameraPath) {
  lod::LodAsset asset = occluderScene();
  for (RasterBackend b : availableRasterBackends(context())) {
    auto withOcclusion = ClusterRenderer::create(context(), asset);
    auto without = ClusterRenderer::create(context(), asset);
    ASSERT_TRUE(withOcclusion.ok() && without.ok());
    Camera front;
    front.eye = {0.0f, 0.5f, 14.0f};
    front.target = {0.0f, 0.0f, 0.0f};
    front.znear = 0.5f;
    front.zfar = 40.0f;
    Camera side = front; // the cut: from the side, where the grid shows
    side.eye = {16.0f, 2.0f, -6.0f};
    side.target = {0.0f, 0.0f, -6.0f};
    std::vector<Camera> path;
    for (int i = 0; i < 3; ++i) { // a slow pan, then the cut, then a pan again
      Camera c = front;
      c.eye.x += 0.3f * float(i);
      path.push_back(c);
    }
    for (int i = 0; i < 2; ++i) {
      Camera c = side;
      c.eye.z += 0.3f * float(i);
      path.push_back(c);
    }
    path.push_back(front); // back: this frame's pass 1 draws the side view's history
    path.push_back(front); // and from here on the grid is culled again
    for (size_t i = 0; i < path.size(); ++i) {
      ClusterRenderSettings s = settingsFor(Bounds{}, 0.5f, b);
      s.base.width = 251; // odd sizes: the HZB's edge texels cover partial blocks
      s.base.height = 189;
      s.base.camera = path[i];
      s.hybridThreshold = 3.0f;
      s.occlusionCulling = true;
      auto on = (*withOcclusion)->render(s);
      s.occlusionCulling = false;
      auto off = (*without)->render(s);
      ASSERT_TRUE(on.ok() && off.ok());
      const ClusterStats &a = on->stats, &o = off->stats;
      double p = psnr(on->image.srgb, off->image.srgb);
      std::printf("%s frame %zu: pass1 %u, late instances %u culled %u, clusters tested %u culled %u, kept %u, "
                  "triangles %llu vs %llu, PSNR %.1f\n",
                  toString(b), i, a.clustersPass1, a.instancesLate, a.instancesOcclusionCulled,
                  a.clustersOcclusionTested, a.clustersOcclusionCulled, a.historyKept,
                  (unsigned long long)a.trianglesRasterized, (unsigned long long)o.trianglesRasterized, p);
      EXPECT_TRUE(a.occlusion);
      EXPECT_GE(p, 60.0) << toString(b) << " frame " << i;
      EXPECT_LE(a.clustersSelected, o.clustersSelected); // occluded instances skip selection
      EXPECT_LE(a.trianglesRasterized, o.trianglesRasterized);
      if (i == 0) { // no history: everything is a candidate and passes the empty HZB
        EXPECT_EQ(a.clustersPass1, 0u);
        EXPECT_EQ(a.trianglesRasterized, o.trianglesRasterized);
      }
      if (i == 1 || i == 2 || i == 6) { // the view of the previous frame (nearly): the grid stays hidden
        EXPECT_GT(a.clustersPass1, 0u);
        EXPECT_GT(a.clustersOcclusionCulled, 0u);
        EXPECT_EQ(a.instancesOcclusionCulled, 144u); // every grid instance is hidden, none selected
        EXPECT_LT(a.trianglesRasterized * 3, o.trianglesRasterized * 2) << toString(b) << " frame " << i;
      }
      writeOnFailure(on->image.srgb, std::string("occlusion_") + toString(b) + std::to_string(i) + ".png");
    }
  }
}

// Normal cones drop clusters facing away from the eye (the far side of a closed mesh) without
// changing the image; mirrored instances keep theirs (their kept side is swapped). A gently bumped
// sphere: its clusters' cones are narrow enough to cull (the test blob's fBm bumps widen them).
TEST_F(ClusterRender, ConeCullingKeepsTheImage) {
  io::BlobOptions o;
  o.subdivisions = 5;
  o.amplitude = 0.03f;
  auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  lod::LodAsset asset = *baked;
  asset.scene.instances.push_back({0, glm::scale(glm::translate(glm::mat4(1.0f), {3.0f, 0, 0}), {-1.0f, 1, 1})});
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 0.01f, RasterBackend::Auto); // level 0
  s.occlusionCulling = false;
  auto on = (*r)->render(s);
  s.coneCulling = false;
  auto off = (*r)->render(s);
  ASSERT_TRUE(on.ok() && off.ok());
  std::printf("cones: %u of %u selected clusters culled\n", on->stats.clustersBackfaceCulled,
              on->stats.clustersSelected);
  // Half the selected clusters are the mirrored copy's: a quarter of the other half is culled.
  EXPECT_GT(on->stats.clustersBackfaceCulled * 8, on->stats.clustersSelected);
  EXPECT_EQ(on->stats.clustersDrawn + on->stats.clustersBackfaceCulled, off->stats.clustersDrawn);
  EXPECT_EQ(off->stats.clustersBackfaceCulled, 0u);
  EXPECT_GE(psnr(on->image.srgb, off->image.srgb), 60.0);
  // The mirrored copy alone: nothing culled.
  lod::LodAsset mirrored = *baked;
  mirrored.scene.instances[0].transform = glm::scale(glm::mat4(1.0f), {-1.0f, 1, 1});
  auto rm = ClusterRenderer::create(context(), mirrored);
  ASSERT_TRUE(rm.ok());
  s.coneCulling = true;
  auto m = (*rm)->render(s);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->stats.clustersBackfaceCulled, 0u);
  writeOnFailure(on->image.srgb, "cones_on.png");
  writeOnFailure(off->image.srgb, "cones_off.png");
}

// More visible instances than a dispatch may have rows (65535): the selection loops rows, so every
// instance's cluster is still selected. An icosahedron (20 triangles, one cluster) keeps it fast.
TEST_F(ClusterRender, SelectsMoreInstancesThanDispatchRows) {
  io::BlobOptions o;
  o.subdivisions = 0;
  auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  lod::LodAsset asset = std::move(*baked);
  ASSERT_EQ(asset.dags[0].clusters.size(), 1u);
  constexpr int kSide = 260; // 67600 instances
  asset.scene.instances.clear();
  for (int z = 0; z < kSide; ++z)
    for (int x = 0; x < kSide; ++x)
      asset.scene.instances.push_back({0, glm::translate(glm::mat4(1.0f), {x * 3.0f, 0.0f, z * 3.0f})});
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 1.0f, RasterBackend::Auto);
  s.base.width = s.base.height = 64;
  s.base.camera.eye = {390.0f, 1500.0f, 391.0f}; // straight down over the grid's centre
  s.base.camera.target = {390.0f, 0.0f, 390.0f};
  s.occlusionCulling = false;
  auto out = (*r)->render(s);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->stats.instancesVisible, uint32_t(kSide * kSide));
  EXPECT_EQ(out->stats.selectRows, 65535u); // the limit a device may enforce (lavapipe does not)
  EXPECT_EQ(out->stats.clustersSelected, uint32_t(kSide * kSide));
  EXPECT_EQ(out->stats.clustersFrustumCulled, 0u);
  EXPECT_EQ(out->stats.clustersOverflow, 0u);
}
