#include "scene_view.h"

#include "mirage/runtime/scene.h"
#include "mirage/runtime/scene_argument.h"

namespace mirage::viewer {

namespace {

runtime::SceneOptions runtimeOptions(const SceneOptions& o) {
  runtime::SceneOptions r;
  r.input = o.path;
  r.pvs = o.pvs;
  r.surfels = o.surfels;
  r.materials = o.materials;
  r.gpuBudget = o.gpuBudget;
  r.source.bandwidthBitsPerSecond = o.bandwidth;
  return r;
}

runtime::View runtimeView(const View& view, bool readImage) {
  runtime::View v;
  v.camera = view.camera;
  v.width = view.width;
  v.height = view.height;
  v.config = view.config;
  v.readImage = readImage;
  v.stereoIpd = view.stereoIpd;
  return v;
}

FrameStats frameStats(runtime::Frame& out, int cell) {
  FrameStats stats;
  stats.passTimes = std::move(out.passTimes);
  stats.triangles = out.trianglesDrawn;
  stats.clusters = out.clustersDrawn;
  stats.surfels = out.surfelsSplatted;
  stats.cell = cell;
  return stats;
}

} // namespace

SceneView::SceneView(std::unique_ptr<runtime::Scene> scene) : scene_(std::move(scene)) {}
SceneView::~SceneView() = default;

Result<runtime::SceneKind> SceneView::check(const SceneOptions& options) {
  // The forward path restricts the scene to the eye's cell and fails outside every cell: a camera
  // flying out of the cells would end the viewer.
  if (!options.pvs.empty() && !runtime::isMrgPath(options.path))
    return makeError(options.path, "--pvs in the viewer applies to .mrg cluster-LOD assets only");
  return runtime::sceneKind(runtimeOptions(options));
}

Result<std::unique_ptr<SceneView>> SceneView::open(gpu::Context& context, const SceneOptions& options) {
  if (auto kind = check(options); !kind) return kind.error();
  auto scene = runtime::Scene::open(context, runtimeOptions(options));
  if (!scene) return scene.error();
  return std::unique_ptr<SceneView>(new SceneView(std::move(*scene)));
}

Result<Frame> SceneView::render(const View& view) {
  auto out = scene_->render(runtimeView(view, true));
  if (!out) return out.error();
  const runtime::PvsState& pvs = scene_->pvs();
  Frame frame;
  frame.srgb = std::move(out->srgb);
  frame.stats = frameStats(*out, !pvs.active ? -2 : pvs.cell < 0 ? -1 : pvs.cell);
  return frame;
}

Status SceneView::record(VkCommandBuffer cmd, const View& view, uint32_t slot) {
  return scene_->record(cmd, runtimeView(view, false), slot);
}

Result<FrameStats> SceneView::collect(uint32_t slot) {
  auto out = scene_->collect(slot);
  if (!out) return out.error();
  // The cell the slot's frame culled with (-1 also when PVS culling was off for it).
  return frameStats(*out, !scene_->pvs().active ? -2 : out->pvsCell);
}

const gpu::Image* SceneView::colorTarget() const { return scene_->colorTarget(); }

const Bounds& SceneView::bounds() const { return scene_->bounds(); }
bool SceneView::clusterLod() const { return scene_->kind() == runtime::SceneKind::ClusterLod; }
bool SceneView::hasSurfels() const { return scene_->info().surfels > 0; }
bool SceneView::hasPvs() const { return scene_->pvs().active; }
bool SceneView::hasBlend() const { return clusterLod() && scene_->info().blendMaterials; }
bool SceneView::mixed() const { return clusterLod() && hasSurfels(); }

} // namespace mirage::viewer
