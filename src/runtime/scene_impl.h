#pragma once
// runtime::Scene's state, shared by the files of each path (scene.cpp dispatches).
#include <memory>
#include <optional>
#include <vector>

#include "mirage/asset/container.h"
#include "mirage/lod/cluster_pvs.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/runtime/scene.h"
#include "mirage/shading/material_file.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::runtime {

struct Scene::Impl {
  gpu::Context& ctx;
  SceneOptions options;
  SceneKind kind = SceneKind::Forward;
  Bounds bounds;
  SceneInfo info;
  PvsState pvsState;
  vis::PvsData pvs;                // the triangle PVS (options.pvs)
  shading::MaterialFile materials; // options.materials, read before the scene (applied by each path)

  // ClusterLod: the asset, its renderer, the mixed scene's per-mesh clouds (kept alive for the
  // surfel renderer) and the current cell's cluster PVS.
  lod::LodAsset asset;
  // GPU residency (options.gpuBudget): the paged asset's index, root pages and reader, from which
  // the renderer reads every other page on demand (asset.dags stays empty; asset.scene is its scene).
  std::optional<lod::PagedLodAsset> paged;
  std::unique_ptr<render::ClusterRenderer> cluster;
  std::vector<surfels::MeshSurfels> meshClouds;
  lod::ClusterPvs clusterPvs;
  int slotCell[render::kMaxFramesInFlight] = {-1, -1, -1}; // record(): the PVS cell of each slot's frame

  // Forward: the scene, its renderer and what it draws (with a PVS the cell's visible triangles,
  // set on the renderer when the eye changes cell): now, and in each recorded slot's frame.
  struct ForwardDrawn {
    int cell = -1;
    uint64_t triangles = 0, instances = 0;
  };
  mirage::Scene scene;
  std::unique_ptr<render::ForwardRenderer> forward;
  std::vector<uint64_t> forwardOffsets; // with a PVS: each instance's first global triangle ID
  ForwardDrawn forwardDrawn;
  ForwardDrawn slotForward[render::kMaxFramesInFlight];

  // Surfels: the surfel-only cloud, or the far field of a mixed scene.
  surfels::SurfelCloud cloud;
  Material cloudMaterial;
  std::unique_ptr<render::SurfelRenderer> surfels;

  explicit Impl(gpu::Context& c) : ctx(c) {}
};

// Per path (scene_lod.cpp, scene_forward.cpp, scene_surfels.cpp): open fills the Impl, render one
// frame. pvs_cell.cpp: the PVS of each path.
Status openClusterLod(Scene::Impl& s);
Result<Frame> renderClusterLod(Scene::Impl& s, const View& view);
Status recordClusterLod(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot);
Result<Frame> collectClusterLod(Scene::Impl& s, uint32_t slot);
Status openForward(Scene::Impl& s);
Result<Frame> renderForward(Scene::Impl& s, const View& view);
Status recordForward(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot);
Result<Frame> collectForward(Scene::Impl& s, uint32_t slot);
Status openSurfels(Scene::Impl& s);
Result<Frame> renderSurfels(Scene::Impl& s, const View& view);
Status recordSurfels(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot);
Result<Frame> collectSurfels(Scene::Impl& s, uint32_t slot);
Status openPvs(Scene::Impl& s);
Result<bool> selectPvsCell(Scene::Impl& s, glm::vec3 eye);

} // namespace mirage::runtime
