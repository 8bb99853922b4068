// Surfel stereo and frames in flight (docs/render.md, "Stereo" and "Frames in flight"): a stereo
// surfel frame (SurfelRenderer alone, or the surfel stage of a mixed mesh/surfel cluster frame)
// holds in each half what a mono render of that eye's camera shows (PSNR >= 45 dB), from one
// prefix selection splatted into both halves; frames recorded into every slot and submitted
// before any wait give exactly the images and counters of sequential render() calls.
// The object: blob:4 baked in memory, and a 6000-surfel cloud of it (64² × 16 views, exact CPU
// farthest-point order).
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "gpu_test.h"
#include "render/render_test_util.h"
#include "render/surfel_test_util.h"
#include "test_support.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"
#include "mirage/shaderio/lod_error.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kStereoWidth = 96, kStereoHeight = 80;
constexpr float kStereoSurfelSize = 2.0f;

// The object: blob:4 and its 6000-surfel cloud, and the blob's LOD asset (baked in memory).
const test::SurfelBlob& stereoBlob() { return test::smallSurfelBlob(); }
const lod::LodAsset& stereoBlobAsset() {
  static const lod::LodAsset asset = [] {
    auto baked = lod::bakeLodAsset(stereoBlob().scene, lod::BuildConfig{});
    if (!baked) std::abort();
    return std::move(*baked);
  }();
  return asset;
}

// Three copies side by side, in front of a camera looking at the middle one: the outer copies are
// nearer to one eye than to the other, so the prefix selection from the nearer eye matters.
std::vector<glm::mat4> threeCopies() {
  float step = 2.5f * stereoBlob().sphere().w;
  std::vector<glm::mat4> t;
  for (int i = -1; i <= 1; ++i) t.push_back(glm::translate(glm::mat4(1.0f), {i * step, 0.0f, 0.0f}));
  return t;
}

RenderSettings stereoViewSettings(const Camera& camera) {
  RenderSettings s;
  s.width = kStereoWidth;
  s.height = kStereoHeight;
  s.camera = camera;
  s.background = {0.1f, 0.2f, 0.3f, 1.0f};
  return s;
}

} // namespace

class SurfelStereo : public test::GpuTest {
protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!test::gpuContext().caps().int64BufferAtomics) GTEST_SKIP() << "surfel stereo needs 64-bit buffer atomics";
  }
};

// Copies straight ahead at growing depth (each as far from both eyes, so the nearer eye's prefix
// is each eye's own), a wide baseline so that the halves differ.
TEST_F(SurfelStereo, EachHalfMatchesAMonoRenderOfThatEye) {
  glm::vec4 sphere = stereoBlob().sphere();
  float r = sphere.w;
  std::vector<glm::mat4> copies;
  for (glm::vec3 at : {glm::vec3(0.0f), glm::vec3(0.0f, 1.2f * r, -4.0f * r), glm::vec3(0.0f, -1.5f * r, -8.0f * r)})
    copies.push_back(glm::translate(glm::mat4(1.0f), at - glm::vec3(sphere)));
  auto renderer = SurfelRenderer::create(context(), stereoBlob().placed(copies, /*linked=*/false));
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  Camera camera;
  camera.eye = {0.0f, 0.0f, 4.0f * r};
  camera.target = {0.0f, 0.0f, 0.0f};
  float ipd = 0.6f * r;
  auto eyes = stereoEyes(camera, ipd);
  for (SurfelMerge merge : {SurfelMerge::Off, SurfelMerge::On}) {
    SCOPED_TRACE(toString(merge));
    SurfelRenderSettings s;
    s.base = stereoViewSettings(camera);
    s.surfelSize = kStereoSurfelSize;
    s.merge = merge;
    s.stereoIpd = ipd;
    auto stereo = (*renderer)->render(s);
    ASSERT_TRUE(stereo.ok()) << stereo.error().message;
    ASSERT_EQ(stereo->image.srgb.width, 2 * kStereoWidth);
    ASSERT_EQ(stereo->image.srgb.height, kStereoHeight);
    // One pass each: one prefix selection, one splat over both eyes, one resolve.
    EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "prefix"), 1);
    EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "splat"), 1);
    EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "resolve"), 1);
    ImageRGBA8 halves[2] = {test::stereoHalf(stereo->image.srgb, 0), test::stereoHalf(stereo->image.srgb, 1)};
    EXPECT_LT(psnr(halves[0], halves[1]), 30.0) << "the eyes see the same image";
    for (uint32_t e = 0; e < 2; ++e) {
      SurfelRenderSettings m = s;
      m.stereoIpd.reset();
      m.base.camera = eyes[e];
      auto mono = (*renderer)->render(m);
      ASSERT_TRUE(mono.ok()) << mono.error().message;
      EXPECT_EQ(mono->surfelsSplatted, stereo->surfelsSplatted) << "eye " << e;
      EXPECT_GE(psnr(halves[e], mono->image.srgb), 45.0) << "eye " << e;
    }
  }
}

// Copies side by side, the outer ones nearer to one eye: the one selection gives each copy the
// prefix of its nearer eye, the larger of the two mono prefixes (frustum culling off, so that
// every copy has one in both eyes).
TEST_F(SurfelStereo, OnePrefixSelectionFromTheNearerEye) {
  std::vector<glm::mat4> copies = threeCopies();
  auto renderer = SurfelRenderer::create(context(), stereoBlob().placed(copies, /*linked=*/false));
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Bounds& bounds = (*renderer)->worldBounds();
  Camera camera = autoCamera(bounds, float(kStereoWidth) / kStereoHeight);
  camera.eye = glm::mix(camera.target, camera.eye, 0.7f);
  SurfelRenderSettings s;
  s.base = stereoViewSettings(camera);
  s.surfelSize = kStereoSurfelSize;
  s.frustumCulling = false;
  s.readInstanceStates = true;
  s.stereoIpd = 0.1f * glm::length(bounds.max - bounds.min);
  auto stereo = (*renderer)->render(s);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  std::vector<uint32_t> mono[2];
  auto eyes = stereoEyes(camera, *s.stereoIpd);
  for (uint32_t e = 0; e < 2; ++e) {
    SurfelRenderSettings m = s;
    m.stereoIpd.reset();
    m.base.camera = eyes[e];
    auto out = (*renderer)->render(m);
    ASSERT_TRUE(out.ok()) << out.error().message;
    mono[e] = out->prefix;
  }
  ASSERT_EQ(stereo->prefix.size(), copies.size());
  bool eyesDiffer = false;
  for (size_t i = 0; i < copies.size(); ++i) {
    EXPECT_EQ(stereo->prefix[i], std::max(mono[0][i], mono[1][i])) << "copy " << i;
    eyesDiffer |= mono[0][i] != mono[1][i];
  }
  EXPECT_TRUE(eyesDiffer) << "the eyes' prefixes are all equal: the test cannot tell the nearer eye";
  // Both eyes' visibility ids in the 2W x H buffer.
  EXPECT_EQ(stereo->idBuffer.size(), size_t(2 * kStereoWidth) * kStereoHeight);
}

TEST_F(SurfelStereo, RefusesTheRasterFallbackAndBadIpd) {
  auto renderer = SurfelRenderer::create(context(), stereoBlob().placed({glm::mat4(1.0f)}, /*linked=*/false));
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  SurfelRenderSettings s;
  s.base = stereoViewSettings(autoCamera((*renderer)->worldBounds(), 1.0f));
  s.stereoIpd = 0.064f;
  s.raster = SurfelRaster::Raster;
  auto raster = (*renderer)->render(s);
  ASSERT_FALSE(raster.ok());
  EXPECT_NE(raster.error().message.find("--stereo"), std::string::npos) << raster.error().message;
  s.raster = SurfelRaster::Auto;
  s.stereoIpd = -1.0f;
  auto bad = (*renderer)->render(s);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--ipd"), std::string::npos) << bad.error().message;
}

// The auto view's direction towards the cloud's sphere, the eye where the reference depth is
// `depthFactor` x the mesh/surfel switch distance for a target `height` pixels high.
Camera stereoCameraAt(float depthFactor, float height) {
  return test::cameraAtSwitchDepth(stereoBlob(), depthFactor, height, kStereoSurfelSize);
}

// Mixed frames: a row of copies straight ahead at growing distance (meshes near, both in the
// band, surfels far; the eyes see each copy at the same distance, so the nearer eye's choices are
// each eye's own), compute raster.
TEST_F(SurfelStereo, MixedFrameHalvesMatchMonoRendersOfEachEye) {
  const test::SurfelBlob& o = stereoBlob();
  Camera base = autoCamera(o.scene.worldBounds(), float(kStereoWidth) / kStereoHeight);
  glm::vec4 s = o.sphere();
  float pixelScale = shaderio::projectionScale(base.projection(1.0f)[1][1], float(kStereoHeight));
  float dSwitch = o.switchDistance(pixelScale, kStereoSurfelSize);
  glm::vec3 forward = glm::normalize(base.target - base.eye);
  base.target = base.eye + forward;
  base.znear = base.zfar = 0.0f;
  std::vector<glm::mat4> transforms;
  for (float factor : {0.5f, 1.2f, 1.8f, 4.0f}) {
    glm::vec3 centre = base.eye + forward * (s.w + factor * dSwitch) + glm::vec3(0.0f, 0.3f * s.w * factor, 0.0f);
    transforms.push_back(glm::translate(glm::mat4(1.0f), centre - glm::vec3(s)));
  }
  auto clusters = ClusterRenderer::create(context(), test::placedAsset(stereoBlobAsset(), transforms));
  auto surfels = SurfelRenderer::create(context(), stereoBlob().placed(transforms, /*linked=*/true));
  ASSERT_TRUE(clusters.ok() && surfels.ok());
  ClusterRenderSettings cs;
  cs.base = stereoViewSettings(base);
  cs.raster = RasterBackend::Compute;
  cs.surfels = surfels->get();
  cs.surfelSettings.surfelSize = kStereoSurfelSize;
  float ipd = 0.5f * s.w;
  cs.stereoIpd = ipd;
  auto stereo = (*clusters)->render(cs);
  ASSERT_TRUE(stereo.ok()) << stereo.error().message;
  ASSERT_EQ(stereo->image.srgb.width, 2 * kStereoWidth);
  EXPECT_GT(stereo->stats.surfels.visibleInstances, 0u);
  EXPECT_GT(stereo->stats.instancesVisible, 0u);
  EXPECT_EQ(test::passCount(stereo->image.stats.passTimes, "splat"), 1);
  auto eyes = stereoEyes(base, ipd);
  for (uint32_t e = 0; e < 2; ++e) {
    ClusterRenderSettings m = cs;
    m.stereoIpd.reset();
    m.base.camera = eyes[e];
    auto mono = (*clusters)->render(m);
    ASSERT_TRUE(mono.ok()) << mono.error().message;
    EXPECT_EQ(mono->stats.surfels.visibleInstances, stereo->stats.surfels.visibleInstances);
    EXPECT_GE(psnr(test::stereoHalf(stereo->image.srgb, e), mono->image.srgb), 45.0) << "eye " << e;
  }
}

class SurfelFrames : public test::GpuTest {
protected:
  void SetUp() override {
    GpuTest::SetUp();
    if (!test::gpuContext().caps().int64BufferAtomics) GTEST_SKIP() << "the compute splat needs 64-bit atomics";
  }
};

// Three different frames (camera, surfel size, stereo and a size change), recorded into the three
// slots before any wait: the same images and counters as sequential render() calls.
TEST_F(SurfelFrames, ThreeFramesInFlightMatchSequentialRenders) {
  static_assert(kMaxFramesInFlight == 3);
  std::vector<glm::mat4> copies = threeCopies();
  auto sequential = SurfelRenderer::create(context(), stereoBlob().placed(copies, /*linked=*/false));
  auto inFlight = SurfelRenderer::create(context(), stereoBlob().placed(copies, /*linked=*/false));
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  Camera far = autoCamera((*sequential)->worldBounds(), 1.0f);
  Camera close = far;
  close.eye = glm::mix(far.target, far.eye, 0.6f);
  std::vector<SurfelRenderSettings> frames(3);
  for (uint32_t i = 0; i < 3; ++i) {
    frames[i].base = stereoViewSettings(i == 1 ? close : far);
    frames[i].base.readLinear = true;
    frames[i].surfelSize = i == 2 ? 3.0f : kStereoSurfelSize;
  }
  frames[2].stereoIpd = 0.05f * glm::length((*sequential)->worldBounds().extent()); // twice as wide
  std::vector<SurfelRenderOutput> expected;
  for (const SurfelRenderSettings& s : frames) {
    auto out = (*sequential)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expected.push_back(std::move(*out));
  }
  EXPECT_NE(expected[0].surfelsSplatted, expected[1].surfelsSplatted);
  // The helper copies width x height from each slot's target: compare the stereo frame's rows
  // through a target of its own width.
  std::vector<std::vector<uint16_t>> pixels[2];
  for (uint32_t pass = 0; pass < 2; ++pass) {
    uint32_t frameCount = pass == 0 ? 3 : 1;
    uint32_t w = pass == 0 ? kStereoWidth : 2 * kStereoWidth;
    pixels[pass] =
        test::recordFramesInFlight(context(), frameCount, w, kStereoHeight,
                                   [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                     // Pass 0: three mono-sized frames (the stereo one in slot 2 is read as its left W
                                     // columns); pass 1: the stereo frame alone, whole.
                                     const SurfelRenderSettings& s = pass == 0 ? frames[slot] : frames[2];
                                     if (Status st = (*inFlight)->record(cmd, s, slot); !st) return st;
                                     color = &(*inFlight)->colorTarget();
                                     return Ok{};
                                   });
    ASSERT_EQ(pixels[pass].size(), size_t(frameCount));
    for (uint32_t i = 0; i < frameCount; ++i) {
      SCOPED_TRACE(std::to_string(pass) + " " + std::to_string(i));
      auto out = (*inFlight)->collect(i);
      ASSERT_TRUE(out.ok()) << out.error().message;
      const SurfelRenderOutput& want = expected[pass == 0 ? i : 2];
      EXPECT_EQ(out->surfelsSplatted, want.surfelsSplatted);
      EXPECT_EQ(out->visibleInstances, want.visibleInstances);
      EXPECT_FALSE(out->image.stats.passTimes.empty());
      std::vector<float> linear = want.image.linear.pixels;
      if (pass == 0 && i == 2) { // the left eye's columns of the stereo image
        uint32_t stride = 2 * kStereoWidth * 4;
        std::vector<float> left;
        for (uint32_t y = 0; y < kStereoHeight; ++y)
          left.insert(left.end(), linear.begin() + y * stride, linear.begin() + y * stride + kStereoWidth * 4);
        linear = std::move(left);
      }
      EXPECT_EQ(test::differingChannels(pixels[pass][i], linear), 0u) << "of " << linear.size() << " channel values";
      EXPECT_FALSE((*inFlight)->collect(i).ok()); // a slot is collected once
    }
  }
  EXPECT_FALSE((*inFlight)->record(VK_NULL_HANDLE, frames[0], kMaxFramesInFlight).ok());
  SurfelRenderSettings states = frames[0];
  states.readInstanceStates = true;
  EXPECT_FALSE((*inFlight)->record(VK_NULL_HANDLE, states, 0).ok());
}

// Mixed frames in flight: the cluster renderer records frames with the surfel stage into every
// slot; images and both renderers' counters match sequential render() calls.
TEST_F(SurfelFrames, MixedFramesInFlightMatchSequentialRenders) {
  std::vector<glm::mat4> copies = threeCopies();
  auto clusters = ClusterRenderer::create(context(), test::placedAsset(stereoBlobAsset(), copies));
  auto surfels = SurfelRenderer::create(context(), stereoBlob().placed(copies, /*linked=*/true));
  ASSERT_TRUE(clusters.ok() && surfels.ok());
  // The middle copy in the band (fading), beyond it, and between (switch distances: docs/render.md).
  const float depthFactors[3] = {1.3f, 2.5f, 1.8f};
  std::vector<ClusterRenderSettings> frames(3);
  for (uint32_t i = 0; i < 3; ++i) {
    frames[i].base = stereoViewSettings(stereoCameraAt(depthFactors[i], float(kStereoHeight)));
    frames[i].base.width = frames[i].base.height = kStereoHeight;
    frames[i].base.readLinear = true;
    frames[i].raster = RasterBackend::Compute;
    frames[i].surfels = surfels->get();
    frames[i].surfelSettings.surfelSize = i == 2 ? 3.0f : kStereoSurfelSize;
  }
  std::vector<ClusterRenderOutput> expected;
  for (const ClusterRenderSettings& s : frames) {
    auto out = (*clusters)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expected.push_back(std::move(*out));
  }
  EXPECT_NE(expected[0].stats.surfels.surfelsSplatted, expected[1].stats.surfels.surfelsSplatted);
  EXPECT_GT(expected[0].stats.surfels.visibleInstances, 0u);
  std::vector<std::vector<uint16_t>> pixels =
      test::recordFramesInFlight(context(), 3, kStereoHeight, kStereoHeight,
                                 [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                   if (Status st = (*clusters)->record(cmd, frames[slot], slot); !st) return st;
                                   color = &(*clusters)->colorTarget();
                                   return Ok{};
                                 });
  ASSERT_EQ(pixels.size(), 3u);
  for (uint32_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    auto out = (*clusters)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->stats.surfels.surfelsSplatted, expected[i].stats.surfels.surfelsSplatted);
    EXPECT_EQ(out->stats.surfels.visibleInstances, expected[i].stats.surfels.visibleInstances);
    EXPECT_EQ(out->stats.trianglesRasterized, expected[i].stats.trianglesRasterized);
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].image.linear.pixels), 0u);
  }
}
