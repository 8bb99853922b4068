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
  return r;
}

} // namespace

SceneView::SceneView(std::unique_ptr<runtime::Scene> scene) : scene_(std::move(scene)) {}
SceneView::~SceneView() = default;

Status SceneView::check(const SceneOptions& options) {
  // The forward path restricts the scene to the eye's cell and fails outside every cell: a camera
  // flying out of the cells would end the viewer.
  if (!options.pvs.empty() && !runtime::isMrgPath(options.path))
    return makeError(options.path, "--pvs in the viewer applies to .mrg cluster-LOD assets only");
  auto kind = runtime::sceneKind(runtimeOptions(options));
  if (!kind) return kind.error();
  return Ok{};
}

Result<std::unique_ptr<SceneView>> SceneView::open(gpu::Context& context, const SceneOptions& options) {
  if (auto st = check(options); !st) return st.error();
  auto scene = runtime::Scene::open(context, runtimeOptions(options));
  if (!scene) return scene.error();
  return std::unique_ptr<SceneView>(new SceneView(std::move(*scene)));
}

Result<Frame> SceneView::render(const View& view) {
  runtime::View v;
  v.camera = view.camera;
  v.width = view.width;
  v.height = view.height;
  v.config = view.config;
  auto out = scene_->render(v);
  if (!out) return out.error();
  Frame frame;
  frame.srgb = std::move(out->srgb);
  frame.stats.passTimes = std::move(out->passTimes);
  frame.stats.triangles = out->trianglesDrawn;
  frame.stats.clusters = out->clustersDrawn;
  frame.stats.surfels = out->surfelsSplatted;
  const runtime::PvsState& pvs = scene_->pvs();
  frame.stats.cell = !pvs.active ? -2 : pvs.cell < 0 ? -1 : pvs.cell;
  return frame;
}

const Bounds& SceneView::bounds() const { return scene_->bounds(); }
bool SceneView::clusterLod() const { return scene_->kind() == runtime::SceneKind::ClusterLod; }
bool SceneView::hasSurfels() const { return scene_->info().surfels > 0; }
bool SceneView::hasPvs() const { return scene_->pvs().active; }

} // namespace mirage::viewer
