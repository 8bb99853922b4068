// Cluster renderer frames in flight (record / collect): frames recorded into every slot and
// submitted before any wait, as a viewer does, give exactly the images and stats of sequential
// render() calls. Validation (with synchronization validation) must stay silent.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <span>
#include <vector>

#include "gpu_test.h"
#include "render/cluster_test_util.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/particle_draw.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kClusterFramesSize = 96;

// Three different frames: camera, LOD threshold and selection mode (the hierarchical ones read
// their traversal counters back too), so a slot mixing up another's data shows.
std::vector<ClusterRenderSettings> threeFrames(const Bounds& bounds) {
  std::vector<ClusterRenderSettings> frames;
  Camera far = autoCamera(bounds, 1.0f);
  Camera close = far;
  close.eye = glm::mix(far.target, far.eye, 0.5f);
  Camera side = far;
  side.eye = glm::vec3(-far.eye.z, far.eye.y, far.eye.x);
  const Camera cams[3] = {far, close, side};
  const float taus[3] = {1.0f, 4.0f, 0.5f};
  const SelectionMode modes[3] = {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag};
  for (int i = 0; i < 3; ++i) {
    ClusterRenderSettings s;
    s.base.width = s.base.height = kClusterFramesSize;
    s.base.camera = cams[i];
    s.base.background = {0, 0, 0, 1};
    s.base.readLinear = true;
    s.tauPixels = taus[i];
    s.selection = modes[i];
    frames.push_back(s);
  }
  return frames;
}

void expectSameStats(const ClusterStats& a, const ClusterStats& b) {
  EXPECT_EQ(a.instancesVisible, b.instancesVisible);
  EXPECT_EQ(a.clustersTested, b.clustersTested);
  EXPECT_EQ(a.nodesTested, b.nodesTested);
  EXPECT_EQ(a.selectionPasses, b.selectionPasses);
  EXPECT_EQ(a.clustersSelected, b.clustersSelected);
  EXPECT_EQ(a.clustersFrustumCulled, b.clustersFrustumCulled);
  EXPECT_EQ(a.clustersBackfaceCulled, b.clustersBackfaceCulled);
  EXPECT_EQ(a.clustersDrawn, b.clustersDrawn);
  EXPECT_EQ(a.clustersHardware, b.clustersHardware);
  EXPECT_EQ(a.trianglesRasterized, b.trianglesRasterized);
  EXPECT_EQ(a.selection, b.selection);
  EXPECT_EQ(a.raster, b.raster);
}

// Renders threeFrames (after `adjust`) one by one with one renderer, records them into slots 0..2
// of another before any wait (each slot's colour target copied at sizes[slot]; gateFirstFrame: see
// recordFramesInFlight) and expects the stats and linear images of the sequential renders; a slot
// is collected once, and there is no fourth.
void expectFramesInFlightMatchSequential(gpu::Context& ctx,
                                         const std::function<void(std::vector<ClusterRenderSettings>&)>& adjust,
                                         std::span<const VkExtent2D> sizes, bool gateFirstFrame) {
  auto sequential = ClusterRenderer::create(ctx, test::smallBlobAsset());
  auto inFlight = ClusterRenderer::create(ctx, test::smallBlobAsset());
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  std::vector<ClusterRenderSettings> frames = threeFrames((*sequential)->worldBounds());
  adjust(frames);
  std::vector<ClusterRenderOutput> expected;
  for (const ClusterRenderSettings& s : frames) {
    auto out = (*sequential)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expected.push_back(std::move(*out));
  }
  // The stats differ between the frames, or the test could not tell the slots apart.
  EXPECT_NE(expected[0].stats.trianglesRasterized, expected[1].stats.trianglesRasterized);

  std::vector<std::vector<uint16_t>> pixels = test::recordFramesInFlight(
      ctx, sizes,
      [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
        if (Status st = (*inFlight)->record(cmd, frames[slot], slot); !st) return st;
        color = &(*inFlight)->colorTarget();
        return Ok{};
      },
      gateFirstFrame);
  ASSERT_EQ(pixels.size(), size_t(kMaxFramesInFlight));
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expectSameStats(out->stats, expected[i].stats);
    EXPECT_FALSE(out->image.stats.passTimes.empty());
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].image.linear.pixels), 0u)
        << "of " << pixels[i].size() << " channel values";
    EXPECT_FALSE((*inFlight)->collect(i).ok()); // a slot is collected once
  }
  // No fourth slot (refused before anything is recorded).
  EXPECT_FALSE((*inFlight)->record(VK_NULL_HANDLE, frames[0], kMaxFramesInFlight).ok());
}

} // namespace

class ClusterFrames : public test::GpuTest {};

TEST_F(ClusterFrames, ThreeFramesInFlightMatchSequentialRenders) {
  static_assert(kMaxFramesInFlight == 3);
  const VkExtent2D sizes[] = {{kClusterFramesSize, kClusterFramesSize},
                              {kClusterFramesSize, kClusterFramesSize},
                              {kClusterFramesSize, kClusterFramesSize}};
  expectFramesInFlightMatchSequential(
      context(), [](std::vector<ClusterRenderSettings>&) {}, sizes, false);
}

// A size change while frames are in flight (a window resize): three frames of three sizes, the
// middle one stereo (its target twice as wide), recorded with the first frame held back on the GPU
// until all were recorded. No record waits for the device (the replaced targets are retired until
// the frames using them completed, each slot's descriptor set names its own frame's targets), and
// each frame's image is that of a sequential render() of its settings. Validation catches a target
// destroyed or a descriptor set updated while a frame still uses it.
TEST_F(ClusterFrames, ResizeWhileFramesAreInFlightNeitherWaitsNorFreesTargetsInUse) {
  auto resize = [](std::vector<ClusterRenderSettings>& frames) {
    frames[1].base.width = 64;
    frames[1].base.height = 80;
    frames[1].stereoIpd = 0.2f;
    frames[2].base.width = 80;
    frames[2].base.height = 64;
  };
  const VkExtent2D sizes[] = {{kClusterFramesSize, kClusterFramesSize}, {2 * 64, 80}, {80, 64}};
  expectFramesInFlightMatchSequential(context(), resize, sizes, /*gateFirstFrame=*/true);
}

// Particles over the blob: white squares around the centre of `bounds`, some in front of its
// surface, some hidden by it (the depth copy decides).
std::unique_ptr<ParticleDraw> sparkDraw(gpu::Context& ctx, const Bounds& bounds) {
  ParticleSheet white{ImageRGBA8{1, 1, {255, 255, 255, 255}}, 1, 1, false};
  auto draw = ParticleDraw::create(ctx, {&white, 1});
  EXPECT_TRUE(draw.ok()) << (draw.ok() ? "" : draw.error().message);
  if (!draw.ok()) return nullptr;
  glm::vec3 centre = bounds.center(), extent = bounds.extent();
  std::vector<shaderio::RenderParticle> sparks; // copied by setCpuBatches
  for (int i = 0; i < 16; ++i) {
    float t = float(i) * 0.9f;
    glm::vec3 p = centre + 0.6f * extent * glm::vec3(std::sin(t), std::cos(1.3f * t), std::sin(2.1f * t));
    sparks.push_back({p, 0.15f * extent.x, 0.0f, shaderio::particlePackColor({1.0f, 0.9f, 0.6f, 0.7f}), 0, 0});
  }
  ParticleDraw::CpuBatch batch{sparks, 0};
  (*draw)->setCpuBatches({&batch, 1});
  return std::move(*draw);
}

// The frame `s` from `renderer` equals it from a new renderer of the same asset, bit for bit;
// returns the new renderer's stats.
ClusterStats expectSameAsFresh(gpu::Context& ctx, ClusterRenderer& renderer, const ClusterRenderSettings& s) {
  auto fresh = ClusterRenderer::create(ctx, test::smallBlobAsset());
  EXPECT_TRUE(fresh.ok());
  if (!fresh.ok()) return {};
  auto expected = (*fresh)->render(s);
  auto after = renderer.render(s);
  EXPECT_TRUE(expected.ok() && after.ok());
  if (!expected.ok() || !after.ok()) return {};
  EXPECT_GT(expected->stats.trianglesRasterized, 0u);
  const std::vector<float>&a = after->image.linear.pixels, &b = expected->image.linear.pixels;
  EXPECT_EQ(a.size(), b.size());
  size_t differing = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) differing += a[i] != b[i];
  EXPECT_EQ(differing, 0u) << "of " << a.size() << " channel values";
  return expected->stats;
}

// The buffer backends' 64-bit visibility buffer is cleared by the resolve that reads it
// (MIRAGE_FRAME_CLEAR_VIS) instead of by a fill at the next frame's start; frames with a debug
// view or particles (their depth copy reads it after the resolve) leave it for the next frame to
// fill (ClusterFramePlan::clearsVisibility). Whatever ran before, a frame must equal the same
// frame from a fresh renderer: a close view (covering most pixels) then a debug view then a far
// one (covering few), each through compute and hybrid, in mono and stereo; and a close view,
// the same with particles, then the far one.
TEST_F(ClusterFrames, EveryFrameStartsFromAnEmptyVisibilityBuffer) {
  for (RasterBackend raster : {RasterBackend::Compute, RasterBackend::Hybrid}) {
    for (float ipd : {0.0f, 0.2f}) {
      SCOPED_TRACE(std::string(toString(raster)) + (ipd > 0.0f ? " stereo" : " mono"));
      auto reused = ClusterRenderer::create(context(), test::smallBlobAsset());
      ASSERT_TRUE(reused.ok());
      auto draw = sparkDraw(context(), (*reused)->worldBounds());
      ASSERT_TRUE(draw);
      std::vector<ClusterRenderSettings> frames = threeFrames((*reused)->worldBounds());
      for (ClusterRenderSettings& s : frames) {
        s.raster = raster;
        if (ipd > 0.0f) s.stereoIpd = ipd;
      }
      ClusterRenderSettings close = frames[1], far = frames[0];
      ClusterRenderSettings debug = frames[2];
      debug.debugView = DebugView::Clusters;
      debug.stereoIpd.reset(); // debug views are mono
      ClusterRenderSettings sparks = close;
      sparks.particles = draw.get();
      for (const ClusterRenderSettings& s : {close, debug, close, far}) ASSERT_TRUE((*reused)->render(s).ok());
      expectSameAsFresh(context(), **reused, far);
      ASSERT_TRUE((*reused)->render(close).ok());
      {
        SCOPED_TRACE("particles after a cleared frame");
        EXPECT_GT(expectSameAsFresh(context(), **reused, sparks).oitFragments, 0u) << "the particles must show";
      }
      SCOPED_TRACE("after particles");
      expectSameAsFresh(context(), **reused, far);
    }
  }
}
