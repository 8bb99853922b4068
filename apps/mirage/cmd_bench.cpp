// mirage bench ...: performance measurements (GPU times from Vulkan timestamp queries).
// bench render: the forward baseline on a scene, median per-pass GPU times over N frames.
// bench import: importer throughput in MB/s.
// bench build: cluster-LOD bake throughput, memory and size.
// bench pvs: speed-up of drawing only the camera cell's PVS.
#include <chrono>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include <algorithm>
#include <filesystem>
#include <optional>

#include <unistd.h>

#include <cstring>

#include "lod_common.h"
#include "lod_render.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/import.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/runtime/scene.h"
#include "render_common.h"
#include "render_options.h"

namespace mirage::cli {

namespace {

struct BenchRenderOptions {
  runtime::SceneOptions scene;
  std::string size = "1920x1080";
  std::string device;
  int frames = 20;
  double warmupMs = kBenchWarmupMs;
  bool json = false;
  std::string path;       // .mrg only: camera path, each camera timed once
  bool baselines = false; // .mrg only: brute force + discrete LOD chain in the same run
  std::string camera;     // empty = auto 3/4 view
  runtime::RenderConfig config;
  BenchSweeps sweeps;
  RenderConfigOptions given;
  StereoOptions stereo;                 // cluster LOD and forward scenes
  runtime::FrameTimeSettings frameTime; // --target-ms
  CLI::Option* targetMs = nullptr;
};

void runBenchRender(const BenchRenderOptions& o) {
  auto kind = runtime::sceneKind(o.scene);
  if (o.scene.surfels && (!kind || *kind != runtime::SceneKind::ClusterLod))
    return fail(o.scene.input + ": bench render --surfels needs a .mrg with cluster DAGs and SURF chunks (surfel-only: "
                                "mirage bench surfels)");
  if (!kind) return fail(kind.error());
  if (*kind == runtime::SceneKind::ClusterLod) {
    LodRenderRequest r{.scene = o.scene,
                       .camera = o.camera,
                       .path = o.path,
                       .size = o.size,
                       .device = o.device,
                       .config = o.config,
                       .sweeps = o.sweeps,
                       .frames = o.frames,
                       .warmupMs = o.warmupMs,
                       .stats = true,
                       .json = o.json,
                       .baselines = o.baselines,
                       .stereoIpd = o.stereo.ipdOrNone(),
                       .frameTime = o.targetMs->count() ? std::optional(o.frameTime) : std::nullopt};
    return runLodBench(r);
  }
  std::optional<render::Camera> camera; // scene files: a fixed view, e.g. layers filling the screen
  if (!o.camera.empty()) {
    auto c = render::parseCamera(o.camera);
    if (!c) return fail(c.error());
    camera = *c;
  }
  if (o.targetMs->count()) return fail("bench render --target-ms applies to .mrg cluster-LOD assets only");
  if (!o.scene.pvs.empty())
    return fail("bench render --pvs applies to .mrg cluster-LOD assets (scene files: mirage bench pvs)");
  uint32_t width = 0, height = 0;
  if (auto s = parseSize(o.size, width, height); !s) return fail(s.error());
  if (o.frames < 2 || o.frames > 100000) return fail("--frames must be in 2..100000");
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto scene = runtime::Scene::open(**ctx, o.scene);
  if (!scene) return fail(scene.error());
  runtime::View view;
  view.width = width;
  view.height = height;
  view.camera = camera ? *camera : render::autoCamera((*scene)->bounds(), float(width) / float(height));
  view.readImage = false; // no CPU gaps between timed frames (they lower the GPU clock)
  view.stereoIpd = o.stereo.ipdOrNone();
  view.config = o.config; // --oit (the cluster-LOD options were refused above)

  std::vector<std::vector<gpu::PassTime>> frames;
  std::vector<double> wall;
  render::FrameStats lastStats;
  auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < o.frames; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    auto out = (*scene)->render(view);
    if (!out) return fail(out.error());
    // Warm-up: pipeline compilation, first touch of memory, and --warmup-ms of work for the clock.
    if (i == 0 && std::chrono::duration<double, std::milli>(t0 - start).count() < o.warmupMs) {
      --i;
      continue;
    }
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (i == 0) continue;
    frames.push_back(out->passTimes);
    lastStats = out->forward->stats;
  }
  std::vector<gpu::PassTime> times = medianPassTimes(frames);
  wall.erase(wall.begin());
  std::sort(wall.begin(), wall.end());
  double frameMs = times.empty() ? 0.0 : times[0].milliseconds;
  uint64_t triangles = (*scene)->info().sourceTriangles;
  const auto& caps = (*ctx)->caps();
  if (o.json) {
    nlohmann::json j = {{"bench", "render"},       {"input", o.scene.input},
                        {"device", caps.name},     {"width", width},
                        {"height", height},        {"triangles", triangles},
                        {"frames", frames.size()}, {"wall_ms_median_incl_readback", wall[wall.size() / 2]}};
    if (view.stereoIpd) j["stereo_ipd"] = *view.stereoIpd; // both eyes per frame, each width x height
    for (const auto& t : times) j["gpu_ms"][t.name] = t.milliseconds;
    if (frameMs > 0) j["triangles_per_second"] = double(triangles) / (frameMs * 1e-3);
    j["fragment_invocations"] = lastStats.pipeline.fragmentInvocations;
    j["oit"] = render::toString(o.config.oit);
    j["msl"] = lastStats.oit.msl;
    j["oit_dropped"] = lastStats.oit.dropped();
    j["oit_fragments"] = lastStats.oit.fragments;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench render {} on {}: {} triangles at {}x{}{}, {} timed frames (after 1 warm-up)\n", o.scene.input,
             caps.name, triangles, width, height,
             view.stereoIpd ? fmt::format(" per eye (stereo, ipd {})", *view.stereoIpd) : "", frames.size());
  for (const auto& t : times) fmt::print("  gpu {:<8} {:9.3f} ms (median)\n", t.name, t.milliseconds);
  if (frameMs > 0) fmt::print("  {:.1f} M triangles/s (GPU frame time)\n", double(triangles) / (frameMs * 1e-3) * 1e-6);
  fmt::print("  wall per frame incl. readback {:.2f} ms (median)\n", wall[wall.size() / 2]);
  if (lastStats.oit.fragments)
    fmt::print("  oit {}: {} fragments  msl {:.3f}  oit_dropped {}\n", render::toString(o.config.oit),
               lastStats.oit.fragments, lastStats.oit.msl, lastStats.oit.dropped());
}

struct BenchImportOptions {
  std::string input;
  int repeat = 5;
  bool json = false;
};

void runBenchImport(const BenchImportOptions& o) {
  if (o.repeat < 1 || o.repeat > 1000) return fail("--repeat must be in 1..1000");
  std::error_code ec;
  uint64_t bytes = std::filesystem::file_size(o.input, ec);
  if (ec) return fail(makeError(o.input, "cannot read the file size"));
  std::vector<double> seconds;
  size_t triangles = 0;
  for (int i = 0; i < o.repeat; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    auto scene = io::importScene(o.input);
    if (!scene) return fail(scene.error());
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    triangles = scene->meshTriangleCount();
  }
  std::sort(seconds.begin(), seconds.end());
  double median = seconds[seconds.size() / 2];
  double mbps = double(bytes) / 1e6 / median;
  if (o.json) {
    nlohmann::json j = {{"bench", "import"},
                        {"input", o.input},
                        {"bytes", bytes},
                        {"triangles", triangles},
                        {"runs", o.repeat},
                        {"median_seconds", median},
                        {"min_seconds", seconds.front()},
                        {"mb_per_second", mbps}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench import {}: {:.1f} MB, {} triangles, median {:.3f} s (min {:.3f}) over {} runs = {:.0f} MB/s\n",
             o.input, double(bytes) / 1e6, triangles, median, seconds.front(), o.repeat, mbps);
}

struct BenchBuildOptions {
  std::vector<std::string> inputs;
  uint32_t threads = 0;
  float normalWeight = lod::BuildConfig{}.normalWeight;
  bool json = false;
};

void runBenchBuild(const BenchBuildOptions& o) {
  auto scene = loadScenes(o.inputs);
  if (!scene) return fail(scene.error());
  lod::BuildConfig config;
  config.threads = o.threads;
  config.normalWeight = o.normalWeight;
  // Reset the peak-RSS mark so it measures the build alone (Linux: writing 5 to clear_refs).
  if (std::FILE* f = std::fopen("/proc/self/clear_refs", "w")) std::fputs("5", f), std::fclose(f);
  uint64_t rssBefore = procStatusBytes("VmRSS:");
  auto t0 = std::chrono::steady_clock::now();
  auto baked = lod::bakeLodAsset(*scene, config);
  if (!baked) return fail(baked.error());
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  uint64_t peak = procStatusBytes("VmHWM:");
  std::string tmp = (std::filesystem::temp_directory_path() / fmt::format("mirage-bench-{}.mrg", ::getpid())).string();
  if (auto s = lod::saveLodAsset(tmp, *baked); !s) return fail(s.error());
  BuildSummary summary = summarize(*baked, tmp);
  std::filesystem::remove(tmp);
  double tris = double(std::max<uint64_t>(summary.inputTriangles, 1));
  double buildPeak = double(peak > rssBefore ? peak - rssBefore : 0);
  if (o.json) {
    nlohmann::json j = summaryJson(summary);
    j["bench"] = "build";
    j["seconds"] = seconds;
    j["input_triangles_per_second"] = tris / seconds;
    j["peak_rss_bytes"] = peak;
    j["peak_rss_bytes_per_input_triangle"] = double(peak) / tris;
    j["build_peak_bytes_per_input_triangle"] = buildPeak / tris;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench build {}: {} input triangles in {:.2f} s = {:.3f} M triangles/s\n", scene->source,
             summary.inputTriangles, seconds, tris / seconds * 1e-6);
  fmt::print(
      "  peak RSS {:.1f} MB = {:.0f} B per input triangle (build working set above the loaded scene: {:.0f} B)\n",
      double(peak) / 1e6, double(peak) / tris, buildPeak / tris);
  printSummary(summary);
}

struct BenchPvsOptions {
  std::string input;
  std::string pvs;
  std::string size = "1920x1080";
  std::string device;
  int frames = 10;
  bool json = false;
};

double medianFrameMs(render::ForwardRenderer& r, const render::RenderSettings& rs, int frames, ImageRGBA8* image,
                     Status& status) {
  std::vector<double> ms;
  for (int i = 0; i < frames; ++i) {
    render::RenderSettings frame = rs;
    frame.readImage = image && i + 1 == frames; // only the image compared; no CPU gaps between frames
    auto out = r.render(frame);
    if (!out) return status = out.error(), 0.0;
    if (i > 0 && !out->stats.passTimes.empty()) ms.push_back(out->stats.passTimes[0].milliseconds);
    if (image && i + 1 == frames) *image = std::move(out->srgb);
  }
  std::sort(ms.begin(), ms.end());
  return ms.empty() ? 0.0 : ms[ms.size() / 2];
}

// The seed's Table 7.5: for every view cell, cameras at its centre looking four ways; the full
// scene vs the cell's PVS, GPU frame time (median) and the image difference.
void runBenchPvs(const BenchPvsOptions& o) {
  uint32_t width = 0, height = 0;
  if (auto s = parseSize(o.size, width, height); !s) return fail(s.error());
  if (o.frames < 2 || o.frames > 10000) return fail("--frames must be in 2..10000");
  auto scene = loadSceneArgument(o.input);
  if (!scene) return fail(scene.error());
  auto pvs = vis::loadPvs(o.pvs);
  if (!pvs) return fail(pvs.error());
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto full = render::ForwardRenderer::create(**ctx, *scene);
  if (!full) return fail(full.error());
  Bounds bounds = scene->worldBounds();
  nlohmann::json cells = nlohmann::json::array();
  double fullSum = 0.0, pvsSum = 0.0, worstPsnr = 1e30;
  size_t views = 0;
  if (!o.json)
    fmt::print("bench pvs {} with {} on {}: {} cells, {}x{}, 4 views per cell, median of {} frames\n", o.input, o.pvs,
               (*ctx)->caps().name, pvs->cells.size(), width, height, o.frames - 1);
  for (size_t c = 0; c < pvs->cells.size(); ++c) {
    glm::vec3 eye = pvs->cells[c].position;
    int cell = -1;
    auto restricted = restrictSceneToPvs(*scene, *pvs, o.pvs, eye, cell);
    if (!restricted) return fail(restricted.error());
    auto part = render::ForwardRenderer::create(**ctx, *restricted);
    if (!part) return fail(part.error());
    double cellFull = 0.0, cellPvs = 0.0, cellPsnr = 1e30;
    for (const render::Camera& view : cellViewCameras(pvs->cells[c])) {
      render::RenderSettings rs;
      rs.width = width;
      rs.height = height;
      rs.camera = render::withClipPlanes(view, bounds);
      ImageRGBA8 a1, a2;
      Status st = Ok{};
      cellFull += medianFrameMs(**full, rs, o.frames, &a1, st);
      cellPvs += medianFrameMs(**part, rs, o.frames, &a2, st);
      if (!st) return fail(st.error());
      cellPsnr = std::min(cellPsnr, psnr(a1, a2));
      ++views;
    }
    fullSum += cellFull;
    pvsSum += cellPvs;
    worstPsnr = std::min(worstPsnr, cellPsnr);
    double share =
        double(restricted->instancedTriangleCount()) / double(std::max<size_t>(1, scene->instancedTriangleCount()));
    cells.push_back({{"cell", c},
                     {"pvs_triangles", restricted->instancedTriangleCount()},
                     {"share", share},
                     {"full_ms", cellFull / 4},
                     {"pvs_ms", cellPvs / 4},
                     {"speedup", cellFull / std::max(cellPvs, 1e-9)},
                     {"min_psnr", cellPsnr}});
    if (!o.json)
      fmt::print("  cell {:>3}: PVS {:>9} triangles ({:5.1f}%)  full {:8.3f} ms  PVS {:8.3f} ms  speed-up {:5.2f}x  "
                 "min PSNR {:.1f} dB\n",
                 c, restricted->instancedTriangleCount(), share * 100.0, cellFull / 4, cellPvs / 4,
                 cellFull / std::max(cellPvs, 1e-9), cellPsnr);
  }
  double speedup = fullSum / std::max(pvsSum, 1e-9);
  if (o.json) {
    nlohmann::json j = {
        {"bench", "pvs"}, {"input", o.input},   {"pvs", o.pvs},          {"device", (*ctx)->caps().name},
        {"views", views}, {"speedup", speedup}, {"min_psnr", worstPsnr}, {"cells", cells}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print(
      "  overall: full {:.3f} ms, PVS {:.3f} ms per view: {:.2f}x; worst view PSNR {:.1f} dB (inf = identical)\n",
      fullSum / double(views), pvsSum / double(views), speedup, worstPsnr);
}

} // namespace

void addBenchCommand(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Performance measurements (GPU times from timestamp queries)");
  bench->require_subcommand(1);
  addBenchSurfelsCommand(*bench);
  auto* r = bench->add_subcommand("render",
                                  "Median per-pass GPU time over N frames (forward; .mrg: cluster LOD per backend)");
  auto o = std::make_shared<BenchRenderOptions>();
  r->add_option("input", o->scene.input, "Scene file or gen:KIND[:SIZE[:SEED]]")->required();
  r->add_option("--size", o->size, "WxH")->capture_default_str();
  r->add_option("--frames", o->frames, "Frames to render (the first is a warm-up)")->capture_default_str();
  r->add_option("--warmup-ms", o->warmupMs,
                "Untimed frames first for this long (an idle GPU's clock may not rise for short frames alone)")
      ->check(CLI::Range(0.0, 60000.0))
      ->capture_default_str();
  r->add_option("--device", o->device, "Vulkan device name substring or index");
  r->add_flag("--json", o->json, "Print results as JSON");
  o->given = bindRenderConfig(*r, o->config, BindMode::Bench, &o->sweeps);
  bindSceneOptions(*r, o->scene, BindMode::Bench);
  bindStereo(*r, o->stereo);
  o->targetMs = bindFrameTimeTarget(*r, o->frameTime);
  r->add_option("--camera", o->camera, "eye=x,y,z,target=x,y,z[,fov=60][,up=x,y,z]; default: auto 3/4 view");
  r->add_option(
      "--path", o->path,
      ".mrg: camera path (cameras.json, orbit:N or fly:N), each camera timed once; with --gpu-budget each camera is "
      "a cut: time to the first full-quality frame, then --frames frames timed there");
  r->add_flag("--baselines", o->baselines,
              ".mrg: also full-resolution brute force and a discrete LOD chain (forward renderer, same camera)");
  r->callback([o] { runBenchRender(*o); });

  auto* im = bench->add_subcommand("import", "Scene import speed: median wall time and MB/s (welding included)");
  auto io = std::make_shared<BenchImportOptions>();
  im->add_option("input", io->input, "Scene file (.gltf .glb .obj .ply)")->required();
  im->add_option("--repeat", io->repeat, "Runs; the median is reported")->capture_default_str();
  im->add_flag("--json", io->json, "Print results as JSON");
  im->callback([io] { runBenchImport(*io); });

  auto* bb = bench->add_subcommand("build", "Cluster-LOD bake: triangles/s, peak memory, bytes on disk, levels");
  auto bo = std::make_shared<BenchBuildOptions>();
  bb->add_option("inputs", bo->inputs, "Scene files or gen:KIND[:SIZE[:SEED]]")->required();
  bb->add_option("--threads", bo->threads, "Worker threads (0 = all cores)")->capture_default_str();
  bb->add_option("--normal-weight", bo->normalWeight,
                 "Weight of the shading term in the LOD error (0 = geometric error only)")
      ->capture_default_str();
  bb->add_flag("--json", bo->json, "Print results as JSON");
  bb->callback([bo] { runBenchBuild(*bo); });

  auto* bp = bench->add_subcommand("pvs", "PVS culling speed-up: full scene vs the cell's PVS, cameras in every cell");
  auto po = std::make_shared<BenchPvsOptions>();
  bp->add_option("input", po->input, "Scene file or gen:KIND[:SIZE[:SEED]] (the one the PVS was baked for)")
      ->required();
  bp->add_option("--pvs", po->pvs, "PVS .mrg from mirage pvs")->required();
  bp->add_option("--size", po->size, "WxH")->capture_default_str();
  bp->add_option("--frames", po->frames, "Frames per view (the first is a warm-up)")->capture_default_str();
  bp->add_option("--device", po->device, "Vulkan device name substring or index");
  bp->add_flag("--json", po->json, "Print results as JSON");
  bp->callback([po] { runBenchPvs(*po); });

  addBenchRaysCommand(bench);
  addBenchSurfelsSortCommand(*bench);
  addBenchSurfelsSamplerCommand(*bench);
  addBenchSurfelPointsCommand(*bench);
  addBenchParticlesCommand(*bench);
  addBenchStreamCommand(*bench);
}

} // namespace mirage::cli
