#include "scene_view.h"

#include <fmt/format.h>

#include "mirage/core/input_text.h"
#include "mirage/io/import.h"
#include "mirage/lod/cluster_pvs.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_cull.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::viewer {

struct SceneView::Impl {
  SceneOptions options;
  bool lod = false;
  lod::LodAsset asset;
  std::vector<surfels::MeshSurfels> clouds;
  vis::PvsData pvs;
  Bounds bounds;
  gpu::Context* context = nullptr;
  std::unique_ptr<render::ForwardRenderer> forward;
  std::unique_ptr<render::ClusterRenderer> cluster;
  std::unique_ptr<render::SurfelRenderer> surfelRenderer;
  int cell = -2; // cell whose cluster PVS is uploaded (-2: none yet)
  lod::ClusterPvs clusterPvs;
};

namespace {

bool isMrg(const std::string& path) { return path.size() > 4 && path.substr(path.size() - 4) == ".mrg"; }

Status loadSurfels(SceneView::Impl& s) {
  auto clouds = surfels::readSurfelMrgAll(s.options.path);
  if (!clouds) return clouds.error();
  s.clouds = std::move(*clouds);
  for (const surfels::MeshSurfels& m : s.clouds)
    if (m.mesh == surfels::kWholeScene || m.mesh >= s.asset.scene.meshes.size() || m.cloud.size() == 0)
      return makeError(s.options.path, "--surfels needs per-mesh SURF chunks (mirage surfels INPUT --per-mesh "
                                       "--append -o " +
                                           s.options.path + ")");
  return Ok{};
}

Status openSurfels(SceneView::Impl& s) {
  render::SurfelScene scene;
  std::vector<int32_t> cloudOfMesh(s.asset.scene.meshes.size(), -1);
  for (const surfels::MeshSurfels& m : s.clouds) {
    const Mesh& mesh = s.asset.scene.meshes[m.mesh];
    Material material =
        mesh.material < s.asset.scene.materials.size() ? s.asset.scene.materials[mesh.material] : Material{};
    cloudOfMesh[m.mesh] = int32_t(scene.clouds.size());
    scene.clouds.push_back({&m.cloud, material});
  }
  for (uint32_t i = 0; i < s.asset.scene.instances.size(); ++i) {
    const Instance& inst = s.asset.scene.instances[i];
    if (inst.mesh < cloudOfMesh.size() && cloudOfMesh[inst.mesh] >= 0)
      scene.instances.push_back({uint32_t(cloudOfMesh[inst.mesh]), inst.transform, i});
  }
  if (scene.instances.empty()) return makeError(s.options.path, "no instance uses a mesh with a SURF chunk");
  auto renderer = render::SurfelRenderer::create(*s.context, scene);
  if (!renderer) return renderer.error();
  s.surfelRenderer = std::move(*renderer);
  return Ok{};
}

// Uploads the cluster PVS of the cell holding `eye` when the cell changed (outside every cell:
// no culling).
Status selectCell(SceneView::Impl& s, glm::vec3 eye) {
  int cell = vis::findCell(s.pvs.cells, eye);
  if (cell == s.cell) return Ok{};
  s.cell = cell;
  if (cell < 0) return s.cluster->setPvs(nullptr);
  auto set = lod::clusterPvs(s.asset.scene, s.asset.dags, s.asset.sourceClusters, s.pvs.triangles[size_t(cell)]);
  if (!set) return makeError(s.options.pvs, set.error().message);
  s.clusterPvs = std::move(*set);
  return s.cluster->setPvs(&s.clusterPvs);
}

} // namespace

SceneView::SceneView(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SceneView::~SceneView() = default;

Status SceneView::check(const SceneOptions& options) {
  if (std::string problem = inputFileProblem(options.path); !problem.empty()) return makeError(options.path, problem);
  if (!isMrg(options.path) && (!options.pvs.empty() || options.surfels))
    return makeError(options.path, "--pvs and --surfels apply to .mrg cluster-LOD assets only");
  return Ok{};
}

Result<std::unique_ptr<SceneView>> SceneView::open(gpu::Context& context, const SceneOptions& options) {
  if (auto st = check(options); !st) return st.error();
  auto s = std::make_unique<Impl>();
  s->options = options;
  s->context = &context;
  s->lod = isMrg(options.path);
  if (!s->lod) {
    auto scene = io::importScene(options.path);
    if (!scene) return scene.error();
    auto r = render::ForwardRenderer::create(context, *scene);
    if (!r) return r.error();
    s->forward = std::move(*r);
    s->bounds = s->forward->worldBounds();
    return std::unique_ptr<SceneView>(new SceneView(std::move(s)));
  }
  auto asset = lod::loadLodAsset(options.path);
  if (!asset) return asset.error();
  s->asset = std::move(*asset);
  if (s->asset.dags.empty()) return makeError(options.path, "holds no cluster DAG (build it with mirage build)");
  if (options.surfels)
    if (auto st = loadSurfels(*s); !st) return st.error();
  if (!options.pvs.empty()) {
    if (s->asset.sourceClusters.empty())
      return makeError(options.path, "no source-triangle map ('TMAP' chunk): run mirage build again");
    auto pvs = vis::loadPvs(options.pvs);
    if (!pvs) return pvs.error();
    uint64_t triangles = lod::sourceTriangleCount(s->asset.scene, s->asset.sourceClusters);
    if (pvs->sceneTriangles != triangles)
      return makeError(options.pvs, fmt::format("baked for a scene of {} triangles, {} was built from one of {}",
                                                pvs->sceneTriangles, options.path, triangles));
    s->pvs = std::move(*pvs);
  }
  auto r = render::ClusterRenderer::create(context, s->asset);
  if (!r) return r.error();
  s->cluster = std::move(*r);
  s->bounds = s->cluster->worldBounds();
  if (!s->clouds.empty())
    if (auto st = openSurfels(*s); !st) return st.error();
  return std::unique_ptr<SceneView>(new SceneView(std::move(s)));
}

Result<Frame> SceneView::render(const View& view) {
  Impl& s = *impl_;
  Frame frame;
  if (s.forward) {
    render::RenderSettings rs;
    rs.width = view.width;
    rs.height = view.height;
    rs.camera = view.camera;
    auto out = s.forward->render(rs);
    if (!out) return out.error();
    frame.srgb = std::move(out->srgb);
    frame.stats.passTimes = std::move(out->stats.passTimes);
    frame.stats.triangles = out->stats.trianglesSubmitted;
    return frame;
  }
  render::ClusterRenderSettings cs;
  cs.base.width = view.width;
  cs.base.height = view.height;
  cs.base.camera = view.camera;
  cs.tauPixels = view.config.tauPixels;
  cs.raster = view.config.raster;
  cs.occlusionCulling = view.config.occlusion;
  cs.flagBackFaces = view.config.flagBackFaces;
  cs.pvsCulling = view.config.pvs;
  if (s.surfelRenderer && view.config.surfels) {
    cs.surfels = s.surfelRenderer.get();
    cs.surfelSettings.surfelSize = view.config.surfelSize;
  }
  if (!s.pvs.cells.empty())
    if (auto st = selectCell(s, view.camera.eye); !st) return st.error();
  auto out = s.cluster->render(cs);
  if (!out) return out.error();
  frame.srgb = std::move(out->image.srgb);
  frame.stats.passTimes = std::move(out->image.stats.passTimes);
  frame.stats.triangles = out->stats.trianglesRasterized;
  frame.stats.clusters = out->stats.clustersDrawn;
  frame.stats.surfels = out->stats.surfels.surfelsSplatted;
  frame.stats.cell = s.pvs.cells.empty() ? -2 : s.cell;
  return frame;
}

const Bounds& SceneView::bounds() const { return impl_->bounds; }
bool SceneView::clusterLod() const { return impl_->lod; }
bool SceneView::hasSurfels() const { return !impl_->clouds.empty(); }
bool SceneView::hasPvs() const { return !impl_->pvs.cells.empty(); }

} // namespace mirage::viewer
