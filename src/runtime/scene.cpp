// runtime::Scene: picks the path from the input's contents and dispatches to it (scene_lod.cpp,
// scene_forward.cpp, scene_surfels.cpp; the PVS in pvs_cell.cpp).
#include "mirage/runtime/scene.h"

#include <fmt/format.h>

#include "mirage/runtime/scene_argument.h"
#include "scene_impl.h"

namespace mirage::runtime {

const char* toString(SceneKind kind) {
  switch (kind) {
  case SceneKind::ClusterLod:
    return "cluster-lod";
  case SceneKind::Forward:
    return "forward";
  case SceneKind::Surfels:
    return "surfels";
  }
  return "?";
}

// The path for `o`: a .mrg's chunks decide (DAGs: cluster LOD; SURF only: surfels), other inputs
// go to the forward renderer unless surfels are asked for (a surfel .ply).
Result<SceneKind> sceneKind(const SceneOptions& o) {
  if (!isMrgPath(o.input)) return o.surfels ? SceneKind::Surfels : SceneKind::Forward;
  MrgContents c = mrgContents(o.input);
  if (c.clusterDags) return SceneKind::ClusterLod;
  if (o.surfels) return SceneKind::Surfels;
  if (c.surfels)
    return makeError(o.input, "holds surfels only (SURF chunks, no cluster DAG): render it with --surfels");
  if (c.pvs)
    return makeError(o.input,
                     "holds a PVS only (from mirage pvs): render the scene it was baked for with --pvs " + o.input);
  return SceneKind::ClusterLod; // the loader says what is missing
}

Scene::Scene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Scene::~Scene() = default;

Result<std::unique_ptr<Scene>> Scene::open(gpu::Context& context, const SceneOptions& options) {
  if (options.grid < 1 || options.grid > 256) return Error{"--grid must be in 1..256"};
  auto kind = sceneKind(options);
  if (!kind) return kind.error();
  auto impl = std::make_unique<Impl>(context);
  impl->options = options;
  impl->kind = *kind;
  if (!options.materials.empty()) { // read first: a bad material file costs no import
    if (*kind == SceneKind::Surfels) return Error{"--materials does not apply to surfel-only scenes"};
    auto file = shading::loadMaterialFile(options.materials);
    if (!file) return file.error();
    impl->materials = std::move(*file);
  }
  if (options.gpuBudget > 0 && *kind != SceneKind::ClusterLod)
    return Error{fmt::format("{}: --gpu-budget needs a paged cluster-LOD .mrg (mirage build --paged), not a {} scene",
                             options.input, toString(*kind))};
  // The cluster PVS maps source triangles to clusters through the whole DAGs, which the
  // out-of-core path never holds.
  if (options.gpuBudget > 0 && !options.pvs.empty())
    return Error{"--pvs does not apply with --gpu-budget (the cluster PVS needs the whole DAGs): give one of them"};
  Status opened = *kind == SceneKind::ClusterLod ? openClusterLod(*impl)
                  : *kind == SceneKind::Forward  ? openForward(*impl)
                                                 : openSurfels(*impl);
  if (!opened) return opened.error();
  if (!options.pvs.empty())
    if (auto st = openPvs(*impl); !st) return st.error();
  return std::unique_ptr<Scene>(new Scene(std::move(impl)));
}

namespace {

// validate() and what a scene kind's renderer refuses.
Status checkConfig(const RenderConfig& c, SceneKind kind) {
  if (auto st = validate(c); !st) return st.error();
  if (c.debugView != render::DebugView::None && kind != SceneKind::ClusterLod)
    return Error{
        fmt::format("--debug-view needs a cluster LOD scene (.mrg with cluster DAGs), not a {} one", toString(kind))};
  using render::OitMode;
  bool lists = c.oit == OitMode::Auto || c.oit == OitMode::LinkedList;
  bool packed = c.oit == OitMode::Packed || c.oit == OitMode::Fixed;
  if (kind == SceneKind::ClusterLod && !lists && !packed)
    return Error{fmt::format("--oit {}: cluster LOD scenes draw BLEND materials by fixed, packed or linked-list",
                             render::toString(c.oit))};
  if (kind != SceneKind::ClusterLod && packed)
    return Error{fmt::format("--oit {} needs a cluster LOD scene (.mrg with cluster DAGs), not a {} one",
                             render::toString(c.oit), toString(kind))};
  return Ok{};
}

} // namespace

Result<Frame> Scene::render(const View& view) {
  if (auto st = checkConfig(view.config, impl_->kind); !st) return st.error();
  switch (impl_->kind) {
  case SceneKind::ClusterLod:
    return renderClusterLod(*impl_, view);
  case SceneKind::Forward:
    return renderForward(*impl_, view);
  case SceneKind::Surfels:
    return renderSurfels(*impl_, view);
  }
  return Error{"unknown scene kind"};
}

Status Scene::record(VkCommandBuffer cmd, const View& view, uint32_t slot) {
  if (auto st = checkConfig(view.config, impl_->kind); !st) return st.error();
  switch (impl_->kind) {
  case SceneKind::Forward:
    return recordForward(*impl_, cmd, view, slot);
  case SceneKind::Surfels:
    return recordSurfels(*impl_, cmd, view, slot);
  case SceneKind::ClusterLod:
    return recordClusterLod(*impl_, cmd, view, slot);
  }
  return Error{"unknown scene kind"};
}

Result<Frame> Scene::collect(uint32_t slot) {
  switch (impl_->kind) {
  case SceneKind::Forward:
    return collectForward(*impl_, slot);
  case SceneKind::Surfels:
    return collectSurfels(*impl_, slot);
  case SceneKind::ClusterLod:
    return collectClusterLod(*impl_, slot);
  }
  return Error{"unknown scene kind"};
}

const gpu::Image* Scene::colorTarget() const {
  switch (impl_->kind) {
  case SceneKind::Forward:
    return &impl_->forward->colorTarget();
  case SceneKind::Surfels:
    return &impl_->surfels->colorTarget();
  case SceneKind::ClusterLod:
    return &impl_->cluster->colorTarget();
  }
  return nullptr;
}

Result<bool> Scene::selectPvsCell(glm::vec3 eye) { return runtime::selectPvsCell(*impl_, eye); }

SceneKind Scene::kind() const { return impl_->kind; }
const Bounds& Scene::bounds() const { return impl_->bounds; }
const SceneInfo& Scene::info() const { return impl_->info; }
const PvsState& Scene::pvs() const { return impl_->pvsState; }
const SceneOptions& Scene::options() const { return impl_->options; }
gpu::Context& Scene::context() const { return impl_->ctx; }
const vis::PvsData* Scene::pvsData() const { return impl_->pvsState.active ? &impl_->pvs : nullptr; }
const lod::LodAsset* Scene::lodAsset() const { return impl_->kind == SceneKind::ClusterLod ? &impl_->asset : nullptr; }

} // namespace mirage::runtime
