// mirage render INPUT -o out.png: headless rendering through runtime::Scene. Scene files and gen:
// scenes take the forward path, surfel-only files the surfel path (both here); .mrg assets with
// cluster DAGs go to the cluster-LOD path (cmd_render_lod.cpp).
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "lod_render.h"
#include "mirage/io/image_io.h"
#include "mirage/particles/render.h"
#include "mirage/runtime/scene.h"
#include "render_common.h"
#include "render_options.h"

namespace mirage::cli {

namespace {

struct RenderOptions {
  runtime::SceneOptions scene;
  std::string output;
  std::string exr;
  std::string camera;
  std::string size = "1920x1080";
  std::string device;
  int repeat = 1;
  bool stats = false;
  bool json = false;
  std::string progressJson; // .mrg with --gpu-budget: the frames until convergence (lod_progress.h)
  std::string path;         // .mrg only: camera path (cameras.json or orbit:N), one image per camera
  runtime::RenderConfig config;
  RenderConfigOptions given;
  CLI::Option* surfelOrder = nullptr;
  StereoOptions stereo;  // cluster LOD and forward scenes
  std::string particles; // an effect file drawn with the scene (forward and cluster-LOD scenes)
  uint32_t particleFrames = 60;
  std::string particleSim = "cpu";
  bool noSplat = false; // --particles: every particle a billboard
};

LodRenderRequest lodRequest(const RenderOptions& o) {
  return LodRenderRequest{.scene = o.scene,
                          .output = o.output,
                          .exr = o.exr,
                          .camera = o.camera,
                          .path = o.path,
                          .size = o.size,
                          .device = o.device,
                          .config = o.config,
                          .frames = o.repeat,
                          .stats = o.stats,
                          .json = o.json,
                          .progressJson = o.progressJson,
                          .stereoIpd = o.stereo.ipdOrNone(),
                          .particles = o.particles,
                          .particleFrames = o.particleFrames,
                          .particleSim = o.particleSim,
                          .particleSplat = !o.noSplat};
}

struct Rendered {
  runtime::Frame last;
  std::vector<gpu::PassTime> times; // medians over frames 2..N (the first pays for pipeline warm-up)
  size_t framesTimed = 0;
};

// Forward and surfel paths: checks the arguments, opens the scene, renders --repeat frames and
// writes the images. Returns false after fail().
bool renderToFiles(const RenderOptions& o, std::unique_ptr<gpu::Context>& ctx, std::unique_ptr<runtime::Scene>& scene,
                   runtime::View& view, Rendered& out) {
  // Everything cheap before the import and the GPU start.
  if (auto s = parseSize(o.size, view.width, view.height); !s) return fail(s.error()), false;
  if (auto s = checkOutputPath(o.output, {".png"}); !s) return fail(s.error()), false;
  if (!o.exr.empty())
    if (auto s = checkOutputPath(o.exr, {".exr", ".pfm"}); !s) return fail(s.error()), false;
  if (auto s = runtime::validate(o.config); !s) return fail(s.error()), false;
  render::Camera camera;
  if (!o.camera.empty()) {
    auto c = render::parseCamera(o.camera);
    if (!c) return fail(c.error()), false;
    camera = *c;
  }
  if (o.repeat < 1 || o.repeat > 10000) return fail("--repeat must be in 1..10000"), false;
  auto c = openDevice(o.device);
  if (!c) return fail(c.error()), false;
  ctx = std::move(*c);
  auto opened = runtime::Scene::open(*ctx, o.scene);
  if (!opened) return fail(opened.error()), false;
  scene = std::move(*opened);
  view.camera = o.camera.empty() ? render::autoCamera(scene->bounds(), float(view.width) / float(view.height)) : camera;
  view.readLinear = !o.exr.empty();
  view.config = o.config;
  view.stereoIpd = o.stereo.ipdOrNone();
  std::unique_ptr<particles::EffectPlayer> effect;
  if (!o.particles.empty()) {
    auto sim = parseNamed(o.particleSim, "--particle-sim", particles::kSimKindNames);
    if (!sim) return fail(sim.error()), false;
    auto played = particles::playEffect(*ctx, o.particles, o.particleFrames, *sim, 1.0f / 60.0f);
    if (!played) return fail(played.error()), false;
    effect = std::move(*played);
    view.particles = effect->draw();
    if (o.noSplat) (void)view.particles->setSettings({0.0f}); // billboards only (a valid setting)
    view.camera = particles::clipAround(view.camera, scene->bounds(), effect->bounds());
  }
  std::vector<std::vector<gpu::PassTime>> frames;
  for (int i = 0; i < o.repeat; ++i) {
    auto f = scene->render(view);
    if (!f) return fail(f.error()), false;
    frames.push_back(f->passTimes);
    out.last = std::move(*f);
  }
  if (frames.size() > 1) frames.erase(frames.begin());
  out.framesTimed = frames.size();
  out.times = medianPassTimes(frames);
  if (auto s = io::writePng(o.output, out.last.srgb); !s) return fail(s.error()), false;
  if (!o.exr.empty()) {
    auto s = o.exr.ends_with(".pfm") ? io::writePfm(o.exr, out.last.linear) : io::writeExr(o.exr, out.last.linear);
    if (!s) return fail(s.error()), false;
  }
  return true;
}

void runForwardRender(const RenderOptions& o) {
  std::unique_ptr<gpu::Context> ctx;
  std::unique_ptr<runtime::Scene> scene;
  runtime::View view;
  Rendered r;
  if (!renderToFiles(o, ctx, scene, view, r)) return;
  const auto& caps = ctx->caps();
  const runtime::ForwardFrameStats& fw = *r.last.forward;
  if (o.json) {
    nlohmann::json j;
    j["input"] = o.scene.input;
    j["output"] = o.output;
    j["device"] = caps.name;
    j["width"] = view.width;
    j["height"] = view.height;
    if (view.stereoIpd) j["stereo_ipd"] = *view.stereoIpd; // the image is 2 * width wide, left|right
    j["triangles"] = fw.triangles;
    j["instances"] = fw.instances;
    j["import_seconds"] = scene->info().loadSeconds;
    j["frames_timed"] = r.framesTimed;
    for (const auto& t : r.times) j["gpu_ms"][t.name] = t.milliseconds;
    j["draw_calls"] = fw.stats.drawCalls;
    j["oit"] = render::toString(view.config.oit);
    j["msl"] = fw.stats.oit.msl;
    j["oit_dropped"] = fw.stats.oit.dropped();
    j["oit_fragments"] = fw.stats.oit.fragments;
    j["pipeline"] = {{"input_primitives", fw.stats.pipeline.inputPrimitives},
                     {"vertex_invocations", fw.stats.pipeline.vertexInvocations},
                     {"clipping_primitives", fw.stats.pipeline.clippingPrimitives},
                     {"fragment_invocations", fw.stats.pipeline.fragmentInvocations}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} triangles, {} instances{}) at {}x{}{} on {} -> {}\n", o.scene.input, fw.triangles,
             fw.instances, r.last.pvsCell >= 0 ? fmt::format(", PVS of cell {}", r.last.pvsCell) : "", view.width,
             view.height,
             view.stereoIpd ? fmt::format(" per eye (stereo, ipd {}: {}x{} left|right)", *view.stereoIpd,
                                          r.last.srgb.width, r.last.srgb.height)
                            : "",
             caps.name, o.output);
  if (o.stats) {
    fmt::print("import {:.3f} s\n", scene->info().loadSeconds);
    for (const auto& t : r.times)
      fmt::print("gpu {:<8} {:9.3f} ms{}\n", t.name, t.milliseconds, r.framesTimed > 1 ? " (median)" : "");
    fmt::print("draw calls {}  input primitives {}  fragment invocations {}\n", fw.stats.drawCalls,
               fw.stats.pipeline.inputPrimitives, fw.stats.pipeline.fragmentInvocations);
    const render::OitStats& oit = fw.stats.oit;
    fmt::print("oit {}: fragments {}  msl {:.3f}  oit_dropped {} (pool {}, cap {}, layers {})\n",
               render::toString(view.config.oit), oit.fragments, oit.msl, oit.dropped(), oit.poolOverflow,
               oit.capDropped, oit.layersDropped);
  }
}

void runSurfelRender(const RenderOptions& o) {
  std::unique_ptr<gpu::Context> ctx;
  std::unique_ptr<runtime::Scene> scene;
  runtime::View view;
  Rendered r;
  if (!renderToFiles(o, ctx, scene, view, r)) return;
  fmt::print("rendered {} as surfels ({} surfels, {} instances, size {} px, {}, {} order) at {}x{}{} on {} -> {}\n",
             o.scene.input, scene->info().surfels, scene->info().instances, o.config.surfelSize,
             render::toString(r.last.surfels->raster), render::toString(o.scene.surfelOrder), view.width, view.height,
             view.stereoIpd ? fmt::format(" per eye (stereo, ipd {}: {}x{} left|right)", *view.stereoIpd,
                                          r.last.srgb.width, r.last.srgb.height)
                            : "",
             ctx->caps().name, o.output);
  if (o.stats) {
    fmt::print("instances visible {}  surfels splatted {}\n", r.last.surfels->visibleInstances, r.last.surfelsSplatted);
    for (const auto& p : r.times)
      fmt::print("gpu {:<8} {:9.3f} ms{}\n", p.name, p.milliseconds, r.framesTimed > 1 ? " (median)" : "");
  }
}

void runRender(const RenderOptions& o) {
  // The path follows the input's contents (a .mrg's chunk table): flags are checked against it.
  auto kind = runtime::sceneKind(o.scene);
  if (!kind) return fail(kind.error());
  bool surfelOrderGiven = o.surfelOrder->count() > 0;
  if (o.scene.surfels && *kind == runtime::SceneKind::ClusterLod) { // DAGs + SURF: meshes near, surfels far
    if (!o.scene.pvs.empty() || o.given.surfels.back()->count() > 0 || surfelOrderGiven)
      return fail("--pvs, --surfel-raster and --surfel-order do not apply to mixed scenes");
    return runLodRender(lodRequest(o));
  }
  if (!o.particles.empty() && *kind == runtime::SceneKind::Surfels)
    return fail("--particles applies to scene files, gen: scenes and .mrg cluster-LOD assets, not surfel-only scenes");
  if (o.scene.surfels) {
    if (!o.scene.pvs.empty() || !o.exr.empty() || !o.path.empty())
      return fail("--pvs, --exr and --path do not apply to --surfels");
    return runSurfelRender(o);
  }
  if (anyGiven(o.given.surfels) || surfelOrderGiven)
    return fail("--surfel-size, --surfel-raster and --surfel-order need --surfels");
  if (*kind == runtime::SceneKind::ClusterLod) return runLodRender(lodRequest(o));
  if (anyGiven(o.given.clusterLod) || !o.path.empty())
    return fail("--tau, --raster, --path, --hybrid-threshold, --blend-queue-pixels, --occlusion, --cones, "
                "--selection, --blend-raster, --fovea and --debug-view apply to .mrg cluster-LOD assets only");
  runForwardRender(o);
}

} // namespace

void addRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a scene file to PNG (headless)");
  auto o = std::make_shared<RenderOptions>();
  cmd->add_option("input", o->scene.input, "Scene file (.gltf .glb .obj .ply), baked .mrg, or gen:KIND[:SIZE[:SEED]]")
      ->required();
  cmd->add_option("-o,--output", o->output, "Output PNG (8-bit sRGB)")->required();
  cmd->add_option("--exr", o->exr, "Also write the linear float image (.exr, or .pfm)");
  cmd->add_option("--camera", o->camera, "eye=x,y,z,target=x,y,z[,fov=60][,up=x,y,z]; default: auto 3/4 view");
  cmd->add_option("--size", o->size, "WxH")->capture_default_str();
  cmd->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->add_option("--repeat", o->repeat, "Render N frames; timings are medians over frames 2..N")
      ->capture_default_str();
  cmd->add_flag("--stats", o->stats, "Print GPU pass times and pipeline statistics");
  cmd->add_flag("--json", o->json, "Print results as JSON");
  cmd->add_option("--progress-json", o->progressJson,
                  "Paged .mrg with --gpu-budget: write FILE.json with every frame until the residency converged "
                  "(seconds, bytes received, PSNR against the converged image)")
      ->type_name("FILE.json");
  o->given = bindRenderConfig(*cmd, o->config, BindMode::Render);
  cmd->add_option("--path", o->path, ".mrg: camera path, cameras.json, orbit:N or fly:N; writes OUT_0000.png ...");
  o->surfelOrder = bindSceneOptions(*cmd, o->scene, BindMode::Render);
  bindStereo(*cmd, o->stereo);
  cmd->add_option("--particles", o->particles,
                  "A particle effect (.toml) drawn with the scene (not surfel-only scenes)");
  cmd->add_option("--particle-frames", o->particleFrames, "--particles: simulation steps (1/60 s) before the image")
      ->capture_default_str();
  cmd->add_option("--particle-sim", o->particleSim, "--particles: simulation cpu or gpu")->capture_default_str();
  cmd->add_flag("--no-splat", o->noSplat, "--particles: draw every particle as a billboard (no compute splat)");
  cmd->callback([o] { runRender(*o); });
}

} // namespace mirage::cli
