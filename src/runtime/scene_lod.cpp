// runtime::Scene on a .mrg with cluster DAGs: the cluster-LOD renderer, with the file's per-mesh
// surfel clouds far away (mixed scenes, docs/render.md "Mixed scenes") and the view cell's cluster
// PVS (pvs_cell.cpp).
#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "scene_impl.h"

namespace mirage::runtime {

namespace {

// --surfels: the file's per-mesh clouds placed on every instance of their mesh (after the grid),
// each linked to its cluster instance for the cross-fade.
Status openMixedSurfels(Scene::Impl& s) {
  const std::string& input = s.options.input;
  auto clouds = surfels::readSurfelMrgAll(input);
  if (!clouds) return clouds.error();
  s.meshClouds = std::move(*clouds);
  render::SurfelScene scene;
  std::vector<int32_t> cloudOfMesh(s.asset.scene.meshes.size(), -1);
  for (const surfels::MeshSurfels& m : s.meshClouds) {
    if (m.mesh == surfels::kWholeScene)
      return makeError(input, "a whole-scene SURF chunk cannot cross-fade with meshes (write per-mesh clouds: "
                              "mirage surfels INPUT --per-mesh --append -o " +
                                  input + ")");
    if (m.mesh >= cloudOfMesh.size() || m.cloud.size() == 0)
      return makeError(input, fmt::format("SURF chunk for mesh {} of {} (or empty)", m.mesh, cloudOfMesh.size()));
    const Mesh& mesh = s.asset.scene.meshes[m.mesh];
    Material material =
        mesh.material < s.asset.scene.materials.size() ? s.asset.scene.materials[mesh.material] : Material{};
    cloudOfMesh[m.mesh] = int32_t(scene.clouds.size());
    scene.clouds.push_back({&m.cloud, material});
    s.info.surfels += m.cloud.size();
  }
  for (uint32_t i = 0; i < s.asset.scene.instances.size(); ++i) {
    const Instance& inst = s.asset.scene.instances[i];
    if (inst.mesh < cloudOfMesh.size() && cloudOfMesh[inst.mesh] >= 0)
      scene.instances.push_back({uint32_t(cloudOfMesh[inst.mesh]), inst.transform, i});
  }
  if (scene.instances.empty()) return makeError(input, "no instance uses a mesh with a SURF chunk");
  auto renderer = render::SurfelRenderer::create(s.ctx, scene, s.options.surfelOrder);
  if (!renderer) return renderer.error();
  s.surfels = std::move(*renderer);
  return Ok{};
}

} // namespace

namespace {

// GPU residency: only the scene, the paged meshes' indices and their root pages are read now; the
// renderer reads every other page as its feedback asks (docs/render.md, "Residency").
Status openPagedClusterLod(Scene::Impl& s, std::chrono::steady_clock::time_point t0) {
  auto paged = lod::openPagedLodAsset(s.options.input, s.options.source);
  if (!paged) return paged.error();
  s.paged = std::move(*paged);
  mirage::Scene& scene = s.paged->scene;
  if (!s.options.materials.empty())
    if (auto st = shading::applyMaterials(scene, s.materials); !st) return st;
  repeatOnGrid(scene, s.options.grid * s.options.grid);
  s.info.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  render::ClusterResidencySettings residency;
  residency.budgetBytes = s.options.gpuBudget;
  residency.prefetch = s.options.prefetch;
  residency.uploads = s.options.uploads;
  auto renderer = render::ClusterRenderer::create(s.ctx, *s.paged, residency);
  if (!renderer) return renderer.error();
  s.cluster = std::move(*renderer);
  for (const Instance& inst : scene.instances)
    if (inst.mesh < s.paged->meshes.size()) s.info.sourceTriangles += s.paged->meshes[inst.mesh].rest.inputTriangles;
  // The renderer read the scene at creation; the mixed-scene and info paths read it from here.
  s.asset.scene = std::move(scene);
  s.asset.metaJson = s.paged->metaJson;
  return Ok{};
}

} // namespace

Status openClusterLod(Scene::Impl& s) {
  auto t0 = std::chrono::steady_clock::now();
  if (s.options.gpuBudget > 0) {
    if (auto st = openPagedClusterLod(s, t0); !st) return st;
  } else {
    auto asset = lod::loadLodAsset(s.options.input, s.options.source);
    if (!asset) return asset.error();
    s.asset = std::move(*asset);
    if (!s.options.materials.empty())
      if (auto st = shading::applyMaterials(s.asset.scene, s.materials); !st) return st;
    repeatOnGrid(s.asset.scene, s.options.grid * s.options.grid); // the seed's benchmark scenes
    s.info.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    auto renderer = render::ClusterRenderer::create(s.ctx, s.asset);
    if (!renderer) return renderer.error();
    s.cluster = std::move(*renderer);
    for (const Instance& inst : s.asset.scene.instances)
      if (inst.mesh < s.asset.dags.size()) s.info.sourceTriangles += s.asset.dags[inst.mesh].inputTriangles;
  }
  s.bounds = s.cluster->worldBounds();
  s.info.instances = s.asset.scene.instances.size();
  s.info.clusters = s.cluster->clusterCount();
  s.info.blendMaterials = std::any_of(s.asset.scene.materials.begin(), s.asset.scene.materials.end(),
                                      [](const Material& m) { return m.alphaMode == AlphaMode::Blend; });
  if (s.options.surfels) {
    if (auto st = openMixedSurfels(s); !st) return st;
    if (!s.options.pvs.empty()) return Error{"--pvs does not apply to mixed (--surfels) scenes yet"};
  }
  return Ok{};
}

namespace {

render::ClusterRenderSettings clusterSettings(Scene::Impl& s, const View& view) {
  const RenderConfig& c = view.config;
  render::ClusterRenderSettings rs;
  rs.base.width = view.width;
  rs.base.height = view.height;
  rs.base.camera = view.camera;
  rs.base.readImage = view.readImage;
  rs.base.readLinear = view.readLinear;
  rs.cameraCut = view.cameraCut;
  rs.tauPixels = c.tauPixels;
  rs.raster = c.raster;
  rs.blendRaster = c.blendRaster;
  rs.selection = c.selection;
  rs.occlusionCulling = c.occlusionCulling;
  rs.coneCulling = c.coneCulling;
  rs.transparency = c.transparency;
  rs.hybridThreshold = c.hybridThreshold;
  rs.leanRaster = c.leanRaster;
  rs.blendQueuePixels = c.blendQueuePixels;
  if (c.oitNodesPerPixel) rs.oitNodesPerPixel = *c.oitNodesPerPixel;
  if (c.oit != render::OitMode::Auto) rs.oit = c.oit;
  rs.pvsCulling = c.pvsCulling;
  rs.stereoIpd = view.stereoIpd;
  rs.stereoMode = c.stereoMode;
  rs.foveation = c.foveation;
  rs.foveaGaze = c.foveaGaze;
  rs.foveaRadiusDegrees = c.foveaRadiusDegrees;
  rs.debugView = c.debugView;
  rs.particles = view.particles;
  if (s.surfels && c.drawSurfels) {
    rs.surfels = s.surfels.get();
    rs.surfelSettings.surfelSize = c.surfelSize;
    rs.surfelSettings.raster = c.surfelRaster;
  }
  return rs;
}

// The counters every path reports, from the cluster renderer's output (images move along).
Frame clusterFrame(Scene::Impl& s, render::ClusterRenderOutput& o, int pvsCell) {
  Frame f;
  f.srgb = std::move(o.image.srgb);
  f.linear = std::move(o.image.linear);
  f.passTimes = std::move(o.image.stats.passTimes);
  f.trianglesDrawn = o.stats.trianglesRasterized;
  f.clustersDrawn = o.stats.clustersDrawn;
  f.surfelsSplatted = o.stats.surfels.surfelsSplatted;
  f.pvsCell = s.pvsState.active && o.stats.pvs ? pvsCell : -1;
  f.cluster = o.stats;
  return f;
}

} // namespace

Result<Frame> renderClusterLod(Scene::Impl& s, const View& view) {
  if (auto cell = selectPvsCell(s, view.camera.eye); !cell) return cell.error();
  if (s.cluster->hasResidency() && view.readImage) { // an image to keep: the converged residency's
    auto c = s.cluster->renderConverged(clusterSettings(s, view), 256, view.readEveryFrame);
    if (!c) return c.error();
    Frame f = clusterFrame(s, c->output, s.pvsState.cell);
    f.residency = Frame::Residency{c->framesToConverge,      c->converged,
                                   std::move(c->frames),     std::move(c->frameEnds),
                                   std::move(c->frameGpuMs), std::move(c->frameImages)};
    return f;
  }
  auto o = s.cluster->render(clusterSettings(s, view));
  if (!o) return o.error();
  return clusterFrame(s, *o, s.pvsState.cell);
}

Status recordClusterLod(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot) {
  if (auto cell = selectPvsCell(s, view.camera.eye); !cell) return cell.error();
  if (auto st = s.cluster->record(cmd, clusterSettings(s, view), slot); !st) return st;
  s.slotCell[slot] = s.pvsState.cell;
  return Ok{};
}

Result<Frame> collectClusterLod(Scene::Impl& s, uint32_t slot) {
  auto o = s.cluster->collect(slot);
  if (!o) return o.error();
  return clusterFrame(s, *o, s.slotCell[slot]);
}

} // namespace mirage::runtime
