// Cluster-LOD raster backends agreeing with each other on small baked assets: every backend the
// device has gives the same image; the compute raster covers exactly the pixels the hardware
// covers for triangles crossing the near plane and for large ones (its per-thread, tiled and
// lattice walks); hybrid equals compute and hardware. Validation must stay silent.
#include <gtest/gtest.h>

#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/render/cluster_renderer.h"
#include "render/cluster_test_util.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::availableRasterBackends;
using mirage::test::blobAsset;
using mirage::test::settingsFor;
using mirage::test::writeOnFailure;

class ClusterBackends : public test::GpuTest {};

TEST_F(ClusterBackends, BackendsGiveTheSameImage) {
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  std::vector<ClusterRenderOutput> outs;
  for (RasterBackend b : availableRasterBackends(context())) {
    ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 1.0f, b);
    s.occlusionCulling = false; // same cut every frame: the triangle counts compare
    auto out = (*r)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->stats.raster, b);
    outs.push_back(std::move(*out));
  }
  for (size_t i = 0; i < outs.size(); ++i)
    for (size_t j = i + 1; j < outs.size(); ++j) {
      EXPECT_EQ(outs[i].stats.trianglesRasterized, outs[j].stats.trianglesRasterized);
      double v = ssim(outs[i].image.srgb, outs[j].image.srgb);
      EXPECT_GE(v, 0.99) << toString(outs[i].stats.raster) << " vs " << toString(outs[j].stats.raster);
      writeOnFailure(outs[j].image.srgb, std::string("backend_") + toString(outs[j].stats.raster) + ".png");
    }
  writeOnFailure(outs[0].image.srgb, "backend_first.png");
}

namespace {

// Pixels covered in one image and background (`bg`) in the other.
size_t coverageMismatch(const ImageRGBA8& a, const ImageRGBA8& b, glm::vec3 bg) {
  auto isBackground = [&](const uint8_t* p) {
    return p[0] == uint8_t(bg.x * 255) && p[1] == uint8_t(bg.y * 255) && p[2] == uint8_t(bg.z * 255);
  };
  size_t n = 0;
  for (uint32_t y = 0; y < a.height; ++y)
    for (uint32_t x = 0; x < a.width; ++x) n += isBackground(a.at(x, y)) != isBackground(b.at(x, y));
  return n;
}

// One frame of `s` rasterized by compute and by the hardware backend (mesh, else indirect), on a
// green background (for coverageMismatch), occlusion off; nullopt (and a failure) if either fails.
struct ComputeAndHardware {
  ClusterRenderOutput compute, hardware;
};
std::optional<ComputeAndHardware> renderComputeAndHardware(gpu::Context& ctx, ClusterRenderer& r,
                                                           ClusterRenderSettings s) {
  s.base.background = {0.0f, 1.0f, 0.0f, 1.0f};
  s.occlusionCulling = false;
  s.raster = RasterBackend::Compute;
  auto compute = r.render(s);
  s.raster = ctx.caps().meshShader ? RasterBackend::Mesh : RasterBackend::Indirect;
  auto hardware = r.render(s);
  if (!compute.ok() || !hardware.ok()) {
    ADD_FAILURE() << (compute.ok() ? hardware.error().message : compute.error().message);
    return std::nullopt;
  }
  return ComputeAndHardware{std::move(*compute), std::move(*hardware)};
}

} // namespace

// A camera skimming the surface with a near plane that cuts into it: triangles cross the near
// plane (and reach behind the eye). The compute rasterizer clips them as the hardware does, so it
// covers the same pixels as the mesh/indirect backends instead of leaving holes.
TEST_F(ClusterBackends, ComputeClipsTrianglesAtTheNearPlane) {
  if (!context().caps().int64BufferAtomics) GTEST_SKIP() << "no 64-bit buffer atomics";
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 1.0f, RasterBackend::Compute);
  s.base.camera.eye = {0.0f, 0.3f, 1.25f}; // at the surface, looking across and into it
  s.base.camera.target = {0.6f, 0.0f, 0.6f};
  s.base.camera.znear = 0.15f;
  s.base.camera.zfar = 10.0f;
  auto both = renderComputeAndHardware(context(), **r, s);
  ASSERT_TRUE(both);
  const ClusterRenderOutput& compute = both->compute;
  const ClusterRenderOutput& hardware = both->hardware;
  EXPECT_GT(compute.stats.trianglesNearClipped, 0u); // the view really cuts triangles
  const ImageRGBA8& a = compute.image.srgb;
  size_t mismatch = coverageMismatch(a, hardware.image.srgb, {0, 1, 0});
  std::printf("near clip: %u triangles clipped, %zu coverage mismatches, SSIM %.4f\n",
              compute.stats.trianglesNearClipped, mismatch, ssim(a, hardware.image.srgb));
  EXPECT_LE(mismatch, a.width / 4) << "pixels covered by one backend only";
  EXPECT_GE(ssim(a, hardware.image.srgb), 0.99);
  writeOnFailure(a, "nearclip_compute.png");
  writeOnFailure(hardware.image.srgb, "nearclip_hardware.png");
}

// Coarse cuts seen close (tau 2, 6 and 16 px): triangles tens of pixels long, slivers among them.
// The compute rasterizer walks small boxes per thread in 32-bit integers, hands larger ones to the
// workgroup as 8 x 8 tiles or, the largest, as a lattice in 64-bit integers (cluster_raster.glsl);
// every walk must keep exactly the samples the hardware keeps (same ids, so the same pixels), else
// edges shared between triangles of different walks crack or double.
TEST_F(ClusterBackends, ComputeMatchesHardwareOnLargeTriangles) {
  if (!context().caps().int64BufferAtomics) GTEST_SKIP() << "no 64-bit buffer atomics";
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (float tau : {2.0f, 6.0f, 16.0f}) {
    ClusterRenderSettings s = settingsFor((*r)->worldBounds(), tau, RasterBackend::Compute);
    s.base.camera.eye = {0.3f, 0.5f, 1.8f};
    s.base.camera.target = {0.0f, 0.0f, 0.0f};
    s.base.camera.znear = 0.05f;
    s.base.camera.zfar = 10.0f;
    auto both = renderComputeAndHardware(context(), **r, s);
    ASSERT_TRUE(both);
    const ImageRGBA8& a = both->compute.image.srgb;
    const ImageRGBA8& b = both->hardware.image.srgb;
    size_t differ = 0;
    for (uint32_t y = 0; y < a.height; ++y)
      for (uint32_t x = 0; x < a.width; ++x) differ += std::memcmp(a.at(x, y), b.at(x, y), 3) != 0;
    std::printf("tau %g: %llu triangles, %zu of %u pixels differ\n", tau,
                (unsigned long long)both->compute.stats.trianglesRasterized, differ, a.width * a.height);
    EXPECT_EQ(coverageMismatch(a, b, {0, 1, 0}), 0u) << "tau " << tau;
    EXPECT_LE(differ, size_t(a.width)) << "tau " << tau; // ids agree: at most rounding in shading
    writeOnFailure(a, "large_compute_" + std::to_string(int(tau)) + ".png");
    writeOnFailure(b, "large_hardware_" + std::to_string(int(tau)) + ".png");
  }
}

// Hybrid: the selection splits clusters between compute and hardware by projected triangle size;
// with a threshold in the middle of this view's range both lists are used, and the image equals
// compute's and the mesh backend's. Thresholds 0 and "huge" send everything to one side.
TEST_F(ClusterBackends, HybridMatchesComputeAndHardware) {
  const auto& caps = context().caps();
  if (!caps.int64BufferAtomics || !caps.fragmentStoresAndAtomics) GTEST_SKIP() << "no fragment 64-bit atomics";
  const lod::LodAsset& asset = blobAsset();
  auto r = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(r.ok()) << r.error().message;
  // Close enough that the clusters' estimated triangle edges spread over ~3-20 px (measured).
  ClusterRenderSettings s = settingsFor((*r)->worldBounds(), 0.5f, RasterBackend::Compute);
  s.base.camera.eye = {0.0f, 0.4f, 2.2f};
  s.base.camera.target = {0.0f, 0.0f, 0.0f};
  s.base.camera.znear = 0.05f; // no cluster sphere reaches the near plane
  s.base.camera.zfar = 10.0f;
  s.occlusionCulling = false;
  auto compute = (*r)->render(s);
  ASSERT_TRUE(compute.ok()) << compute.error().message;
  s.raster = caps.meshShader ? RasterBackend::Mesh : RasterBackend::Indirect;
  auto hardware = (*r)->render(s);
  ASSERT_TRUE(hardware.ok()) << hardware.error().message;
  s.raster = RasterBackend::Hybrid;
  for (float threshold : {0.0f, 6.0f, 1e6f}) {
    s.hybridThreshold = threshold;
    auto hybrid = (*r)->render(s);
    ASSERT_TRUE(hybrid.ok()) << hybrid.error().message;
    const ClusterStats& st = hybrid->stats;
    std::printf("hybrid threshold %g: %u of %u clusters to hardware\n", threshold, st.clustersHardware,
                st.clustersDrawn);
    EXPECT_EQ(st.clustersDrawn, compute->stats.clustersDrawn);
    EXPECT_EQ(st.trianglesRasterized, compute->stats.trianglesRasterized);
    uint32_t expectedMin = threshold == 0.0f ? st.clustersDrawn : threshold == 6.0f ? 1u : 0u;
    uint32_t expectedMax = threshold == 0.0f ? st.clustersDrawn : threshold == 6.0f ? st.clustersDrawn - 1 : 0u;
    EXPECT_GE(st.clustersHardware, expectedMin) << "threshold " << threshold;
    EXPECT_LE(st.clustersHardware, expectedMax) << "threshold " << threshold;
    EXPECT_GE(ssim(hybrid->image.srgb, compute->image.srgb), 0.99) << "threshold " << threshold;
    EXPECT_GE(ssim(hybrid->image.srgb, hardware->image.srgb), 0.99) << "threshold " << threshold;
    writeOnFailure(hybrid->image.srgb, "hybrid_" + std::to_string(int(threshold)) + ".png");
  }
  writeOnFailure(compute->image.srgb, "hybrid_compute.png");
  writeOnFailure(hardware->image.srgb, "hybrid_hardware.png");
}
