// mirage render INPUT -o out.png: headless forward rendering of a scene file; .mrg assets go to the
// cluster-LOD renderer (cmd_render_lod.cpp).
#include <chrono>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "lod_render.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "render_common.h"
#include "surfel_render.h"

namespace mirage::cli {

namespace {

struct RenderOptions {
  std::string input;
  std::string output;
  std::string exr;
  std::string camera;
  std::string size = "1920x1080";
  std::string device;
  int repeat = 1;
  bool stats = false;
  bool json = false;
  float tau = render::kDefaultTauPixels; // .mrg only
  std::string raster = "auto";           // .mrg only
  std::string pvs;                       // draw only the PVS of the camera's view cell (.mrg: its cluster PVS)
  std::string path;                      // .mrg only: camera path (cameras.json or orbit:N), one image per camera
  bool surfels = false;                  // draw the file's SURF chunk (or surfel PLY) with the surfel renderer
  float surfelSize = 2.0f;
  std::string surfelRaster = "auto";
  std::string surfelOrder; // empty: render::kDefaultSurfelOrder
  LodCullOptions cull;     // .mrg only
};

LodRenderRequest lodRequest(const RenderOptions& o) {
  return LodRenderRequest{.input = o.input,
                          .output = o.output,
                          .exr = o.exr,
                          .camera = o.camera,
                          .path = o.path,
                          .size = o.size,
                          .device = o.device,
                          .raster = o.raster,
                          .tau = o.tau,
                          .frames = o.repeat,
                          .stats = o.stats,
                          .json = o.json,
                          .cull = o.cull,
                          .pvs = o.pvs};
}

void runRender(const RenderOptions& o) {
  if (!o.surfels && isLodAssetPath(o.input)) {
    // A .mrg without DAGs: say which flag its chunks call for.
    MrgContents c = mrgContents(o.input);
    if (!c.clusterDags && c.surfels)
      return fail(o.input + ": holds surfels only (SURF chunks, no cluster DAG): render it with --surfels");
    if (!c.clusterDags && c.pvs)
      return fail(o.input + ": holds a PVS only (from mirage pvs): render the scene it was baked for with --pvs " +
                  o.input);
  }
  if (o.surfels && mrgHasClusterDags(o.input)) { // DAGs + SURF: meshes near, surfels far (one frame)
    if (!o.pvs.empty() || o.surfelRaster != "auto" || !o.surfelOrder.empty())
      return fail("--pvs, --surfel-raster and --surfel-order do not apply to mixed scenes");
    LodRenderRequest r = lodRequest(o);
    r.surfels = true;
    r.surfelSize = o.surfelSize;
    return runLodRender(r);
  }
  if (o.surfels) {
    if (!o.pvs.empty() || !o.exr.empty() || !o.path.empty())
      return fail("--pvs, --exr and --path do not apply to --surfels");
    SurfelRenderRequest r;
    r.input = o.input;
    r.output = o.output;
    r.camera = o.camera;
    r.size = o.size;
    r.device = o.device;
    r.raster = o.surfelRaster;
    r.order = o.surfelOrder;
    r.surfelSize = o.surfelSize;
    r.frames = o.repeat;
    r.stats = o.stats;
    if (o.repeat < 1 || o.repeat > 10000) return fail("--repeat must be in 1..10000");
    return runSurfelRender(r);
  }
  if (o.surfelSize != 2.0f || o.surfelRaster != "auto" || !o.surfelOrder.empty())
    return fail("--surfel-size, --surfel-raster and --surfel-order need --surfels");
  if (isLodAssetPath(o.input)) {
    LodRenderRequest r = lodRequest(o);
    return runLodRender(r);
  }
  if (o.raster != "auto" || o.tau != render::kDefaultTauPixels || !o.path.empty() || !o.cull.isDefault())
    return fail("--tau, --raster, --path, --hybrid-threshold, --occlusion, --cones, --selection and --blend-raster "
                "apply to .mrg cluster-LOD assets only");
  // Check everything cheap before the import and the GPU start.
  uint32_t width = 0, height = 0;
  if (auto s = parseSize(o.size, width, height); !s) return fail(s.error());
  if (auto s = checkOutputPath(o.output, {".png"}); !s) return fail(s.error());
  if (!o.exr.empty())
    if (auto s = checkOutputPath(o.exr, {".exr", ".pfm"}); !s) return fail(s.error());
  render::Camera camera;
  bool autoCam = o.camera.empty();
  if (!autoCam) {
    auto c = render::parseCamera(o.camera);
    if (!c) return fail(c.error());
    camera = *c;
  }
  if (o.repeat < 1 || o.repeat > 10000) return fail("--repeat must be in 1..10000");

  auto t0 = std::chrono::steady_clock::now();
  auto scene = loadSceneArgument(o.input);
  if (!scene) return fail(scene.error());
  double importSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (autoCam) camera = render::autoCamera(scene->worldBounds(), float(width) / float(height));
  int cell = -1;
  if (!o.pvs.empty()) {
    // Clip planes stay those of the whole scene, so the PVS image differs from the full one only
    // where the PVS misses something.
    camera = render::withClipPlanes(camera, scene->worldBounds());
    auto pvs = vis::loadPvs(o.pvs);
    if (!pvs) return fail(pvs.error());
    auto restricted = restrictSceneToPvs(*scene, *pvs, o.pvs, camera.eye, cell);
    if (!restricted) return fail(restricted.error());
    scene = std::move(restricted);
  }

  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto renderer = render::ForwardRenderer::create(**ctx, *scene);
  if (!renderer) return fail(renderer.error());

  render::RenderSettings rs;
  rs.width = width;
  rs.height = height;
  rs.camera = camera;
  rs.readLinear = !o.exr.empty();
  std::vector<std::vector<gpu::PassTime>> frames;
  render::RenderOutput last;
  for (int i = 0; i < o.repeat; ++i) {
    auto out = (*renderer)->render(rs);
    if (!out) return fail(out.error());
    frames.push_back(out->stats.passTimes);
    last = std::move(*out);
  }
  // The first frame pays for pipeline warm-up; with repeats, report the median of the others.
  if (frames.size() > 1) frames.erase(frames.begin());
  std::vector<gpu::PassTime> times = medianPassTimes(frames);

  if (auto s = io::writePng(o.output, last.srgb); !s) return fail(s.error());
  if (!o.exr.empty()) {
    auto s = o.exr.ends_with(".pfm") ? io::writePfm(o.exr, last.linear) : io::writeExr(o.exr, last.linear);
    if (!s) return fail(s.error());
  }

  const auto& caps = (*ctx)->caps();
  size_t triangles = scene->instancedTriangleCount();
  if (o.json) {
    nlohmann::json j;
    j["input"] = o.input;
    j["output"] = o.output;
    j["device"] = caps.name;
    j["width"] = width;
    j["height"] = height;
    j["triangles"] = triangles;
    j["instances"] = scene->instances.size();
    j["import_seconds"] = importSeconds;
    j["frames_timed"] = frames.size();
    for (const auto& t : times) j["gpu_ms"][t.name] = t.milliseconds;
    j["draw_calls"] = last.stats.drawCalls;
    j["pipeline"] = {{"input_primitives", last.stats.pipeline.inputPrimitives},
                     {"vertex_invocations", last.stats.pipeline.vertexInvocations},
                     {"clipping_primitives", last.stats.pipeline.clippingPrimitives},
                     {"fragment_invocations", last.stats.pipeline.fragmentInvocations}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} triangles, {} instances{}) at {}x{} on {} -> {}\n", o.input, triangles,
             scene->instances.size(), cell >= 0 ? fmt::format(", PVS of cell {}", cell) : "", width, height, caps.name,
             o.output);
  if (o.stats) {
    fmt::print("import {:.3f} s\n", importSeconds);
    for (const auto& t : times)
      fmt::print("gpu {:<8} {:9.3f} ms{}\n", t.name, t.milliseconds, frames.size() > 1 ? " (median)" : "");
    fmt::print("draw calls {}  input primitives {}  fragment invocations {}\n", last.stats.drawCalls,
               last.stats.pipeline.inputPrimitives, last.stats.pipeline.fragmentInvocations);
  }
}

} // namespace

void addRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render a scene file to PNG (headless)");
  auto o = std::make_shared<RenderOptions>();
  cmd->add_option("input", o->input, "Scene file (.gltf .glb .obj .ply), baked .mrg, or gen:KIND[:SIZE[:SEED]]")
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
  cmd->add_option("--tau", o->tau, ".mrg: LOD threshold, projected error in pixels")->capture_default_str();
  cmd->add_option("--raster", o->raster, ".mrg: auto|mesh|indirect|compute|hybrid")->capture_default_str();
  addLodCullOptions(*cmd, o->cull, /*bench=*/false);
  cmd->add_option("--path", o->path, ".mrg: camera path, cameras.json or orbit:N; writes OUT_0000.png ...");
  cmd->add_option("--pvs", o->pvs,
                  "Draw only the PVS (from mirage pvs) of the view cell holding the camera (.mrg: its cluster PVS)");
  cmd->add_flag("--surfels", o->surfels, "Render the file's SURF chunk (.mrg from mirage surfels) or surfel .ply");
  cmd->add_option("--surfel-size", o->surfelSize, "--surfels: surfel diameter in pixels")->capture_default_str();
  cmd->add_option("--surfel-raster", o->surfelRaster, "--surfels: auto|compute|raster")->capture_default_str();
  cmd->add_option(
      "--surfel-order", o->surfelOrder,
      "--surfels: splat order blue|coherent|coherent256 (default coherent: Morton-sorted blocks, docs/surfels.md)");
  cmd->callback([o] { runRender(*o); });
}

} // namespace mirage::cli
