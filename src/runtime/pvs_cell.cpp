// The view cell's PVS at run time (docs/visibility.md): cluster LOD culls with the cell's cluster
// PVS (lod::clusterPvs, uploaded when the eye changes cell); the forward path draws only the cell's
// triangle PVS (ForwardRenderer::setVisibleTriangles). Neither waits for frames in flight.
#include <chrono>

#include <fmt/format.h>

#include "mirage/runtime/scene_argument.h"
#include "mirage/visibility/pvs_cull.h"
#include "mirage/visibility/ray_backend.h"
#include "scene_impl.h"

namespace mirage::runtime {

Status openPvs(Scene::Impl& s) {
  const SceneOptions& o = s.options;
  if (s.kind == SceneKind::Surfels) return Error{"--pvs does not apply to surfel-only scenes"};
  if (s.kind == SceneKind::ClusterLod && s.asset.sourceClusters.empty())
    return makeError(o.input, "no source-triangle map ('TMAP' chunk): built before cluster PVS support, run mirage "
                              "build again");
  auto pvs = vis::loadPvs(o.pvs);
  if (!pvs) return pvs.error();
  if (s.kind == SceneKind::ClusterLod) {
    uint64_t triangles = lod::sourceTriangleCount(s.asset.scene, s.asset.sourceClusters);
    if (pvs->sceneTriangles != triangles)
      return Error{fmt::format("{}: baked for a scene of {} triangles, {} was built from one of {} (a PVS of another "
                               "scene, or --grid?)",
                               o.pvs, pvs->sceneTriangles, o.input, triangles)};
  } else if (auto st = checkPvsScene(s.scene, *pvs, o.pvs); !st) {
    return st;
  } else {
    s.forwardOffsets = vis::triangleOffsets(s.scene);
  }
  s.pvs = std::move(*pvs);
  s.pvsState.active = true;
  s.pvsState.cells = s.pvs.cells.size();
  return Ok{};
}

namespace {

Result<bool> selectClusterCell(Scene::Impl& s, int cell) {
  PvsState& st = s.pvsState;
  st.cell = cell;
  st.cellTriangles = 0;
  st.visibleInstances = 0;
  st.visibleClusters = 0;
  st.bytes = 0;
  st.milliseconds = 0.0;
  if (cell < 0) { // outside every cell: nothing culled
    if (auto r = s.cluster->setPvs(nullptr); !r) return r.error();
    return true;
  }
  auto t0 = std::chrono::steady_clock::now();
  auto set = lod::clusterPvs(s.asset.scene, s.asset.dags, s.asset.sourceClusters, s.pvs.triangles[size_t(cell)]);
  if (!set) return makeError(s.options.pvs, set.error().message);
  s.clusterPvs = std::move(*set);
  st.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  st.cellTriangles = s.pvs.triangles[size_t(cell)].size();
  st.visibleInstances = s.clusterPvs.visibleInstances;
  st.visibleClusters = s.clusterPvs.visibleClusters;
  st.bytes = s.clusterPvs.bytes();
  if (auto r = s.cluster->setPvs(&s.clusterPvs); !r) return r.error();
  return true;
}

// The forward renderer draws the cell's PVS triangles from the next frame on; an eye in no cell is
// an error (there is no culling to fall back on without drawing everything).
Result<bool> selectForwardCell(Scene::Impl& s, glm::vec3 eye) {
  auto cell = pvsCellOf(s.pvs, s.options.pvs, eye);
  if (!cell) return cell.error();
  if (*cell == s.pvsState.cell) return false;
  const std::vector<uint32_t>& ids = s.pvs.triangles[size_t(*cell)];
  if (auto st = s.forward->setVisibleTriangles(&ids); !st) return makeError(s.options.pvs, st.error().message);
  uint64_t instances = 0; // those with a triangle in the PVS (ids and offsets ascend: one merge)
  for (size_t i = 0, k = 0; i + 1 < s.forwardOffsets.size() && k < ids.size(); ++i) {
    instances += ids[k] < s.forwardOffsets[i + 1];
    while (k < ids.size() && ids[k] < s.forwardOffsets[i + 1]) ++k;
  }
  s.forwardDrawn = {*cell, ids.size(), instances};
  s.pvsState.cell = *cell;
  s.pvsState.cellTriangles = ids.size();
  return true;
}

} // namespace

Result<bool> selectPvsCell(Scene::Impl& s, glm::vec3 eye) {
  if (!s.pvsState.active) return false;
  if (s.kind == SceneKind::Forward) return selectForwardCell(s, eye);
  int cell = vis::findCell(s.pvs.cells, eye);
  if (cell == s.pvsState.cell) return false;
  return selectClusterCell(s, cell);
}

} // namespace mirage::runtime
