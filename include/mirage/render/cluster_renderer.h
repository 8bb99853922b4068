#pragma once
// GPU-driven cluster-LOD renderer for baked .mrg assets (issue 4, first slice). Per frame the CPU
// records a fixed command sequence whatever the scene size:
//   instance cull -> cluster selection (LOCALCUT + frustum) -> raster args ->
//   visibility raster (mesh shaders | one indirect draw | compute 64-bit atomics) -> resolve.
// Every backend writes the same visibility semantics (visible-cluster index + triangle id, nearest
// depth wins) and one resolve pass shades it with the forward renderer's material model, so all
// backends give the same image. Passes and data layout: docs/render.md.
#include <memory>
#include <string>
#include <string_view>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"

namespace mirage::render {

enum class RasterBackend {
  Auto,     // mesh shaders when the device has them, else indirect draws
  Mesh,     // VK_EXT_mesh_shader: one mesh workgroup per visible cluster
  Indirect, // one vkCmdDrawIndirect: an instance per visible cluster, 3 x 128 vertices each
  Compute,  // software rasterizer: atomicMax of (depth << 32 | id) into a 64-bit buffer
};
const char* toString(RasterBackend backend);
// "auto", "mesh", "indirect" or "compute"; anything else is an error naming the choices.
Result<RasterBackend> parseRasterBackend(std::string_view text);

struct ClusterRenderSettings {
  RenderSettings base;                        // size, camera, lighting, background
  float tauPixels = 1.0f;                     // LOD threshold: projected error allowed, in pixels
  RasterBackend raster = RasterBackend::Auto; // resolved against the device at render time
  bool frustumCulling = true;                 // instances and clusters outside the view are skipped
  bool flagBackFaces = false;                 // debug: draw back faces in magenta (crack tests)
};

struct ClusterStats {
  uint32_t instancesVisible = 0;
  uint32_t clustersTested = 0;                // (instance, cluster) pairs the selection pass looked at
  uint32_t clustersSelected = 0;              // on the LOCALCUT cut and inside the frustum
  uint32_t clustersFrustumCulled = 0;         // on the cut but outside the frustum
  uint32_t clustersOverflow = 0;              // selected beyond the visible-buffer capacity (dropped)
  uint64_t trianglesRasterized = 0;           // triangles of the selected clusters
  RasterBackend raster = RasterBackend::Auto; // the backend that ran
};

struct ClusterRenderOutput {
  RenderOutput image; // srgb (+ linear), pass times in image.stats.passTimes
  ClusterStats stats;
};

class ClusterRenderer {
public:
  // Uploads every DAG, the instances, materials and textures. Refuses clusters larger than the
  // mesh-shader limits (MIRAGE_CLUSTER_MAX_TRIANGLES / _VERTICES) with a clear error.
  static Result<std::unique_ptr<ClusterRenderer>> create(gpu::Context& context, const lod::LodAsset& asset);
  ~ClusterRenderer();

  Result<ClusterRenderOutput> render(const ClusterRenderSettings& settings);
  const Bounds& worldBounds() const;
  uint64_t clusterCount() const; // all DAG clusters uploaded (not per instance)

  struct Impl;

private:
  explicit ClusterRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::render
