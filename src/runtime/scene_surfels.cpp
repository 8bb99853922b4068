// runtime::Scene on a surfel-only .mrg (SURF chunk) or surfel .ply: the surfel renderer draws the
// cloud once, in place.
#include "mirage/runtime/scene_argument.h"
#include "scene_impl.h"

namespace mirage::runtime {

Status openSurfels(Scene::Impl& s) {
  auto cloud = loadSurfelCloud(s.options.input, s.cloudMaterial);
  if (!cloud) return cloud.error();
  s.cloud = std::move(*cloud);
  render::SurfelScene scene;
  scene.clouds.push_back({&s.cloud, s.cloudMaterial});
  scene.instances.push_back({0, glm::mat4(1.0f)});
  auto renderer = render::SurfelRenderer::create(s.ctx, scene, s.options.surfelOrder);
  if (!renderer) return renderer.error();
  s.surfels = std::move(*renderer);
  s.bounds = s.surfels->worldBounds();
  s.info.surfels = s.surfels->surfelCount();
  s.info.instances = 1;
  return Ok{};
}

namespace {

render::SurfelRenderSettings surfelSettings(const View& view) {
  render::SurfelRenderSettings rs;
  rs.base.width = view.width;
  rs.base.height = view.height;
  rs.base.camera = view.camera;
  rs.base.readImage = view.readImage;
  rs.base.readLinear = view.readLinear;
  rs.surfelSize = view.config.surfelSize;
  rs.raster = view.config.surfelRaster;
  rs.stereoIpd = view.stereoIpd;
  return rs;
}

Frame surfelFrame(render::SurfelRenderOutput& o) {
  Frame f;
  f.srgb = std::move(o.image.srgb);
  f.linear = std::move(o.image.linear);
  f.passTimes = std::move(o.image.stats.passTimes);
  f.surfelsSplatted = o.surfelsSplatted;
  f.surfels = SurfelFrameStats{o.raster, o.visibleInstances, o.fadingInstances};
  return f;
}

} // namespace

Result<Frame> renderSurfels(Scene::Impl& s, const View& view) {
  auto o = s.surfels->render(surfelSettings(view));
  if (!o) return o.error();
  return surfelFrame(*o);
}

Status recordSurfels(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot) {
  return s.surfels->record(cmd, surfelSettings(view), slot);
}

Result<Frame> collectSurfels(Scene::Impl& s, uint32_t slot) {
  auto o = s.surfels->collect(slot);
  if (!o) return o.error();
  return surfelFrame(*o);
}

} // namespace mirage::runtime
