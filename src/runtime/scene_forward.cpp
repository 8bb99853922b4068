// runtime::Scene on a scene file or generated scene: the forward renderer draws every triangle (of
// the view cell's PVS with one, pvs_cell.cpp).
#include <chrono>

#include "mirage/runtime/scene_argument.h"
#include "scene_impl.h"

namespace mirage::runtime {

Status openForward(Scene::Impl& s) {
  auto t0 = std::chrono::steady_clock::now();
  auto scene = loadSceneArgument(s.options.input);
  if (!scene) return scene.error();
  s.info.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.scene = std::move(*scene);
  if (!s.options.materials.empty())
    if (auto st = shading::applyMaterials(s.scene, s.materials); !st) return st;
  s.bounds = s.scene.worldBounds();
  s.info.sourceTriangles = s.scene.instancedTriangleCount();
  s.info.instances = s.scene.instances.size();
  for (const Material& m : s.scene.materials) s.info.blendMaterials |= m.alphaMode == AlphaMode::Blend;
  auto renderer = render::ForwardRenderer::create(s.ctx, s.scene);
  if (!renderer) return renderer.error();
  s.forward = std::move(*renderer);
  s.forwardDrawn = {-1, s.info.sourceTriangles, s.info.instances};
  return Ok{};
}

namespace {

render::ForwardRenderSettings forwardSettings(const Scene::Impl& s, const View& view) {
  render::ForwardRenderSettings fs;
  render::RenderSettings& rs = fs.base;
  rs.width = view.width;
  rs.height = view.height;
  rs.camera = view.camera;
  // With a PVS the clip planes stay those of the whole scene, so the image differs from the full
  // one only where the PVS misses something.
  if (s.pvsState.active) rs.camera = render::withClipPlanes(view.camera, s.bounds);
  rs.readImage = view.readImage;
  rs.readLinear = view.readLinear;
  fs.stereoIpd = view.stereoIpd;
  if (view.config.oit != render::OitMode::Auto) fs.oit = view.config.oit;
  if (view.config.oitNodesPerPixel) fs.oitNodesPerPixel = *view.config.oitNodesPerPixel;
  fs.particles = view.particles;
  return fs;
}

// The counters every path reports, from the forward renderer's output (images move along).
Frame forwardFrame(render::RenderOutput& o, const Scene::Impl::ForwardDrawn& drawn) {
  Frame f;
  f.srgb = std::move(o.srgb);
  f.linear = std::move(o.linear);
  f.passTimes = o.stats.passTimes;
  f.trianglesDrawn = drawn.triangles;
  f.pvsCell = drawn.cell;
  f.forward = ForwardFrameStats{std::move(o.stats), drawn.triangles, drawn.instances};
  return f;
}

} // namespace

Result<Frame> renderForward(Scene::Impl& s, const View& view) {
  if (auto cell = selectPvsCell(s, view.camera.eye); !cell) return cell.error();
  auto o = s.forward->render(forwardSettings(s, view));
  if (!o) return o.error();
  return forwardFrame(*o, s.forwardDrawn);
}

// A cell change only swaps the renderer's visible triangles, which outlive the frames reading them.
Status recordForward(Scene::Impl& s, VkCommandBuffer cmd, const View& view, uint32_t slot) {
  if (auto cell = selectPvsCell(s, view.camera.eye); !cell) return cell.error();
  if (auto st = s.forward->record(cmd, forwardSettings(s, view), slot); !st) return st;
  s.slotForward[slot] = s.forwardDrawn;
  return Ok{};
}

Result<Frame> collectForward(Scene::Impl& s, uint32_t slot) {
  auto o = s.forward->collect(slot);
  if (!o) return o.error();
  return forwardFrame(*o, s.slotForward[slot]);
}

} // namespace mirage::runtime
