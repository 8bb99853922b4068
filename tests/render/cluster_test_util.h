#pragma once
// Helpers shared by the cluster renderer's test files (and render_test_util.h's).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/gpu/context.h"
#include "mirage/io/generate.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "render/render_test_util.h"
#include "test_support.h"

namespace mirage::test {

// The raster backends the device can run (indirect always; mesh, compute and hybrid by feature).
inline std::vector<render::RasterBackend> availableRasterBackends(const gpu::Context& ctx) {
  std::vector<render::RasterBackend> list{render::RasterBackend::Indirect};
  if (ctx.caps().meshShader) list.push_back(render::RasterBackend::Mesh);
  bool compute = ctx.caps().int64BufferAtomics && ctx.caps().int64SharedAtomics; // cluster_frame.cpp's condition
  if (compute) list.push_back(render::RasterBackend::Compute);
  if (compute && ctx.caps().fragmentStoresAndAtomics) list.push_back(render::RasterBackend::Hybrid);
  return list;
}

// One frame of `asset` with a fresh renderer; a failure to create or render fails the test.
inline render::ClusterRenderOutput renderCluster(gpu::Context& ctx, const lod::LodAsset& asset,
                                                 const render::ClusterRenderSettings& s) {
  auto r = render::ClusterRenderer::create(ctx, asset);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  auto out = (*r)->render(s);
  EXPECT_TRUE(out.ok()) << (out.ok() ? "" : out.error().message);
  return std::move(*out);
}

// A blob of 5120 triangles (4 subdivisions) baked with the default build, once per process.
inline const lod::LodAsset& smallBlobAsset() {
  static lod::LodAsset asset = [] {
    io::BlobOptions o;
    o.subdivisions = 4;
    auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
    if (!baked) std::abort();
    return std::move(*baked);
  }();
  return asset;
}

// Size of the cluster renderer tests' square images.
inline constexpr uint32_t kClusterTestSize = 256;

inline lod::LodAsset bakeTestBlob(float normalWeight) {
  io::BlobOptions o;
  o.subdivisions = 5;
  lod::BuildConfig config;
  config.normalWeight = normalWeight;
  auto baked = lod::bakeLodAsset(io::generateBlob(o), config);
  if (!baked) std::abort();
  return std::move(*baked);
}

// A closed blob (20480 triangles) baked in memory: a few DAG levels, quick on lavapipe. Built with
// the geometric error: the selection and culling tests need cuts coarser than the input at 256²,
// where the blob's triangles are ~2 px and the shading-aware default keeps nearly all of them.
inline const lod::LodAsset& blobAsset() {
  static lod::LodAsset asset = bakeTestBlob(0.0f);
  return asset;
}

// The same blob with the default (shading-aware) error.
inline const lod::LodAsset& defaultBlobAsset() {
  static lod::LodAsset asset = bakeTestBlob(lod::BuildConfig{}.normalWeight);
  return asset;
}

// kClusterTestSize² from the automatic camera on black, at `tau` pixels with `raster`.
inline render::ClusterRenderSettings settingsFor(const Bounds& bounds, float tau, render::RasterBackend raster) {
  render::ClusterRenderSettings s;
  s.base.width = s.base.height = kClusterTestSize;
  s.base.camera = render::autoCamera(bounds, 1.0f);
  s.base.background = {0, 0, 0, 1};
  s.tauPixels = tau;
  s.raster = raster;
  return s;
}

// `scene` baked with the default build; a failure fails the test (and returns an empty asset).
inline lod::LodAsset bakeScene(const Scene& scene) {
  auto baked = lod::bakeLodAsset(scene, lod::BuildConfig{});
  EXPECT_TRUE(baked.ok()) << (baked.ok() ? "" : baked.error().message);
  return baked.ok() ? std::move(*baked) : lod::LodAsset{};
}

} // namespace mirage::test
