#pragma once
// Helpers shared by the cluster renderer's test files.
#include <cstdlib>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "mirage/gpu/context.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"

namespace mirage::test {

// The raster backends the device can run (indirect always; mesh, compute and hybrid by feature).
inline std::vector<render::RasterBackend> availableRasterBackends(const gpu::Context& ctx) {
  std::vector<render::RasterBackend> list{render::RasterBackend::Indirect};
  if (ctx.caps().meshShader) list.push_back(render::RasterBackend::Mesh);
  if (ctx.caps().int64BufferAtomics) list.push_back(render::RasterBackend::Compute);
  if (ctx.caps().int64BufferAtomics && ctx.caps().fragmentStoresAndAtomics)
    list.push_back(render::RasterBackend::Hybrid);
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

} // namespace mirage::test
