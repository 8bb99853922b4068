// mirage render / bench render on .mrg assets through the cluster-LOD renderer.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lod_baselines.h"
#include "lod_render.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/asset/container.h"
#include "mirage/lod/cluster_pvs.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_cull.h"
#include "mirage/visibility/pvs_storage.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct Session {
  std::unique_ptr<gpu::Context> ctx;
  lod::LodAsset asset;
  std::unique_ptr<render::ClusterRenderer> renderer;
  render::ClusterRenderSettings settings;
  std::vector<render::Camera> path; // --path: frame i uses path[i % size]
  double loadSeconds = 0.0;
  std::vector<surfels::MeshSurfels> clouds; // --surfels: per-mesh clouds (kept alive for the renderer)
  std::unique_ptr<render::SurfelRenderer> surfelRenderer;
  // --pvs: the triangle PVS, the cell whose cluster PVS is uploaded (-2: none yet, -1: outside
  // every cell) and that set's figures for the report.
  std::string pvsPath;
  vis::PvsData pvs;
  int pvsCell = -2;
  lod::ClusterPvs clusterPvs;
  double clusterPvsMs = 0.0;
};

// Uploads the cluster PVS of the cell holding `eye` when it changed; outside every cell the
// renderer culls nothing (said once). Returns false after fail().
bool selectPvsCell(Session& s, glm::vec3 eye, bool quiet) {
  if (s.pvsPath.empty()) return true;
  int cell = vis::findCell(s.pvs.cells, eye);
  if (cell == s.pvsCell) return true;
  s.pvsCell = cell;
  if (cell < 0) {
    if (!quiet)
      fmt::print("PVS: the camera at ({:.4g}, {:.4g}, {:.4g}) is in none of the {} view cells: no PVS culling\n", eye.x,
                 eye.y, eye.z, s.pvs.cells.size());
    if (auto st = s.renderer->setPvs(nullptr); !st) return fail(st.error()), false;
    return true;
  }
  auto t0 = std::chrono::steady_clock::now();
  auto set = lod::clusterPvs(s.asset.scene, s.asset.dags, s.asset.sourceClusters, s.pvs.triangles[size_t(cell)]);
  if (!set) return fail(s.pvsPath + ": " + set.error().message), false;
  s.clusterPvs = std::move(*set);
  s.clusterPvsMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (auto st = s.renderer->setPvs(&s.clusterPvs); !st) return fail(st.error()), false;
  if (!quiet)
    fmt::print("PVS: cell {} of {}: {} triangles -> {} of {} instances, {} (instance, cluster) pairs visible; "
               "{} bytes uploaded, made in {:.2f} ms\n",
               cell, s.pvs.cells.size(), s.pvs.triangles[size_t(cell)].size(), s.clusterPvs.visibleInstances,
               s.asset.scene.instances.size(), s.clusterPvs.visibleClusters, s.clusterPvs.bytes(), s.clusterPvsMs);
  return true;
}

// --pvs: loads the triangle PVS and checks it was baked for the asset's source scene. Returns false
// after fail().
bool openPvs(const LodRenderRequest& r, Session& s) {
  if (s.asset.sourceClusters.empty())
    return fail(r.input + ": no source-triangle map ('TMAP' chunk): built before cluster PVS support, run mirage "
                          "build again"),
           false;
  auto pvs = vis::loadPvs(r.pvs);
  if (!pvs) return fail(pvs.error()), false;
  uint64_t triangles = lod::sourceTriangleCount(s.asset.scene, s.asset.sourceClusters);
  if (pvs->sceneTriangles != triangles)
    return fail(fmt::format("{}: baked for a scene of {} triangles, {} was built from one of {} (a PVS of another "
                            "scene, or --grid?)",
                            r.pvs, pvs->sceneTriangles, r.input, triangles)),
           false;
  s.pvs = std::move(*pvs);
  s.pvsPath = r.pvs;
  return true;
}

// Cameras at every view cell's centre looking four ways (as `bench pvs`).
std::vector<render::Camera> cellCameras(const vis::PvsData& pvs) {
  std::vector<render::Camera> cams;
  for (const vis::ViewCell& cell : pvs.cells)
    for (const render::Camera& c : cellViewCameras(cell)) cams.push_back(c);
  return cams;
}

// --surfels: the file's per-mesh clouds placed on every instance of their mesh (after --grid), each
// linked to its cluster instance for the cross-fade. Returns false after fail().
bool openSurfels(const LodRenderRequest& r, Session& s) {
  auto clouds = surfels::readSurfelMrgAll(r.input);
  if (!clouds) return fail(clouds.error()), false;
  s.clouds = std::move(*clouds);
  render::SurfelScene scene;
  std::vector<int32_t> cloudOfMesh(s.asset.scene.meshes.size(), -1);
  for (const surfels::MeshSurfels& m : s.clouds) {
    if (m.mesh == surfels::kWholeScene)
      return fail(r.input +
                  ": a whole-scene SURF chunk cannot cross-fade with meshes (write per-mesh clouds: "
                  "mirage surfels INPUT --per-mesh --append -o " +
                  r.input + ")"),
             false;
    if (m.mesh >= cloudOfMesh.size() || m.cloud.size() == 0)
      return fail(fmt::format("{}: SURF chunk for mesh {} of {} (or empty)", r.input, m.mesh, cloudOfMesh.size())),
             false;
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
  if (scene.instances.empty()) return fail(r.input + ": no instance uses a mesh with a SURF chunk"), false;
  auto renderer = render::SurfelRenderer::create(*s.ctx, scene);
  if (!renderer) return fail(renderer.error()), false;
  s.surfelRenderer = std::move(*renderer);
  s.settings.surfels = s.surfelRenderer.get();
  s.settings.surfelSettings.surfelSize = r.surfelSize;
  return true;
}

// "on" / "off" (and "both" where allowed) of a culling option; false after fail().
bool parseSwitch(const std::string& value, const char* option, bool allowBoth) {
  if (value == "on" || value == "off" || (allowBoth && value == "both")) return true;
  fail(fmt::format("{} '{}': expected on, off{}", option, value, allowBoth ? " or both" : ""));
  return false;
}

// Checks the arguments, loads the asset, starts the GPU. Returns false after fail().
bool open(const LodRenderRequest& r, bool needOutput, Session& s) {
  uint32_t width = 0, height = 0;
  if (auto st = parseSize(r.size, width, height); !st) return fail(st.error()), false;
  if (needOutput) {
    if (auto st = checkOutputPath(r.output, {".png"}); !st) return fail(st.error()), false;
    if (!r.exr.empty())
      if (auto st = checkOutputPath(r.exr, {".exr", ".pfm"}); !st) return fail(st.error()), false;
  }
  if (!(r.tau > 0.0f) || r.tau > 1e6f) return fail("--tau must be a positive number of pixels"), false;
  if (!(r.cull.hybridThreshold >= 0.0f) || r.cull.hybridThreshold > 1e6f)
    return fail("--hybrid-threshold must be a number of pixels in 0..1e6"), false;
  if (!parseSwitch(r.cull.occlusion, "--occlusion", /*allowBoth=*/!needOutput)) return false;
  if (!parseSwitch(r.cull.cones, "--cones", /*allowBoth=*/false)) return false;
  // bench: --selection all times flat, hierarchy and dag in one run (runLodBench).
  bool allSelections = r.cull.selection == "all" && !needOutput;
  auto selection = render::parseSelectionMode(allSelections ? "auto" : r.cull.selection);
  if (!selection) return fail(selection.error()), false;
  if (!(!needOutput && r.cull.blendRaster == "all"))
    if (auto blend = render::parseBlendRaster(r.cull.blendRaster); !blend) return fail(blend.error()), false;
  render::Camera camera;
  if (!r.camera.empty()) {
    auto c = render::parseCamera(r.camera);
    if (!c) return fail(c.error()), false;
    camera = *c;
  }
  auto t0 = std::chrono::steady_clock::now();
  auto asset = lod::loadLodAsset(r.input);
  if (!asset) return fail(asset.error()), false;
  s.asset = std::move(*asset);
  if (r.grid < 1 || r.grid > 256) return fail("--grid must be in 1..256"), false;
  repeatOnGrid(s.asset.scene, r.grid * r.grid); // the seed's benchmark scenes
  s.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto ctx = openDevice(r.device);
  if (!ctx) return fail(ctx.error()), false;
  s.ctx = std::move(*ctx);
  auto renderer = render::ClusterRenderer::create(*s.ctx, s.asset);
  if (!renderer) return fail(renderer.error()), false;
  s.renderer = std::move(*renderer);
  if (r.surfels) {
    if (!(r.surfelSize >= 0.5f && r.surfelSize <= 16.0f)) return fail("--surfel-size must be in 0.5..16 pixels"), false;
    if (!openSurfels(r, s)) return false;
  }
  s.settings.base.width = width;
  s.settings.base.height = height;
  s.settings.base.camera =
      r.camera.empty() ? render::autoCamera(s.renderer->worldBounds(), float(width) / float(height)) : camera;
  if (!r.path.empty()) {
    if (!r.camera.empty()) return fail("give --camera or --path, not both"), false;
    auto path = render::cameraPathArgument(r.path, s.renderer->worldBounds(), float(width) / float(height));
    if (!path) return fail(path.error()), false;
    s.path = std::move(*path);
    s.settings.base.camera = s.path[0];
  }
  s.settings.base.readLinear = !r.exr.empty();
  s.settings.tauPixels = r.tau;
  s.settings.hybridThreshold = r.cull.hybridThreshold;
  s.settings.occlusionCulling = r.cull.occlusion != "off";
  s.settings.coneCulling = r.cull.cones == "on";
  s.settings.selection = *selection;
  if (auto blend = render::parseBlendRaster(r.cull.blendRaster)) s.settings.blendRaster = *blend; // else bench "all"
  if (!r.pvs.empty()) {
    if (r.surfels) return fail("--pvs does not apply to mixed (--surfels) scenes yet"), false;
    if (!openPvs(r, s)) return false;
    if (!needOutput && r.camera.empty() && r.path.empty()) { // bench: views from every cell
      s.path = cellCameras(s.pvs);
      s.settings.base.camera = s.path[0];
    }
    if (!selectPvsCell(s, s.settings.base.camera.eye, /*quiet=*/r.json || !s.path.empty())) return false;
  }
  return true;
}

struct Timed {
  std::vector<gpu::PassTime> times; // medians over the timed frames
  render::ClusterRenderOutput last;
  size_t frames = 0;
  double maxFrameMs = 0.0;       // slowest timed frame (on a camera path the median hides the worst view)
  double meanTriangles = 0.0;    // triangles rasterized per timed frame
  double meanPvsInstances = 0.0; // --pvs: instances culled by the cell's PVS per timed frame
  double meanPvsClusters = 0.0;  // --pvs: cut clusters culled by it
  size_t framesOutsideCells = 0; // --pvs: timed frames whose camera was in no view cell
};

// Renders `frames` frames; with more than one, the first (pipeline warm-up) is not timed. On a
// camera path, frame i uses camera i - 1 (the warm-up repeats camera 0); `onFrame` sees each
// timed frame's output with its camera index. The warm-up frame repeats until `warmupMs` of wall
// time have passed: a GPU left idle sits at a low clock, and short frames alone may not raise it
// (on the H200 a whole process then ran 5.4x slower, every pass alike).
template <class OnFrame>
bool renderFrames(Session& s, int frames, Timed& out, OnFrame&& onFrame, double warmupMs = 0.0) {
  std::vector<std::vector<gpu::PassTime>> all;
  auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < frames; ++i) {
    size_t cameraIndex = frames > 1 ? size_t(std::max(i - 1, 0)) : 0;
    if (!s.path.empty()) s.settings.base.camera = s.path[cameraIndex % s.path.size()];
    if (!selectPvsCell(s, s.settings.base.camera.eye, /*quiet=*/s.path.size() > 1)) return false;
    auto o = s.renderer->render(s.settings);
    if (!o) return fail(o.error()), false;
    if (i == 0 && frames > 1 &&
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() < warmupMs) {
      --i; // still warming up: this frame again
      continue;
    }
    all.push_back(o->image.stats.passTimes);
    if (i > 0 || frames == 1) {
      if (!onFrame(*o, cameraIndex)) return false;
      out.meanTriangles += double(o->stats.trianglesRasterized);
      out.meanPvsInstances += o->stats.instancesPvsCulled;
      out.meanPvsClusters += o->stats.clustersPvsCulled;
      out.framesOutsideCells += !s.pvsPath.empty() && s.pvsCell < 0;
    }
    out.last = std::move(*o);
  }
  if (all.size() > 1) all.erase(all.begin());
  out.frames = all.size();
  for (double* mean : {&out.meanTriangles, &out.meanPvsInstances, &out.meanPvsClusters})
    *mean /= double(std::max<size_t>(out.frames, 1));
  out.times = medianPassTimes(all);
  for (const auto& f : all) out.maxFrameMs = std::max(out.maxFrameMs, frameMilliseconds(f));
  return true;
}
bool renderFrames(Session& s, int frames, Timed& out, double warmupMs = 0.0) {
  return renderFrames(
      s, frames, out, [](const render::ClusterRenderOutput&, size_t) { return true; }, warmupMs);
}

// out.png -> out_0007.png: one image per camera of a path.
std::string pathFrameName(const std::string& output, size_t index) {
  std::filesystem::path p = output;
  return (p.parent_path() / fmt::format("{}_{:04}{}", p.stem().string(), index, p.extension().string())).string();
}

nlohmann::json statsJson(const render::ClusterStats& st) {
  return {{"raster", render::toString(st.raster)},
          {"selection", render::toString(st.selection)},
          {"nodes_tested", st.nodesTested},
          {"selection_passes", st.selectionPasses},
          {"occlusion", st.occlusion},
          {"instances_visible", st.instancesVisible},
          {"clusters_tested", st.clustersTested},
          {"clusters_selected", st.clustersSelected},
          {"clusters_frustum_culled", st.clustersFrustumCulled},
          {"clusters_backface_culled", st.clustersBackfaceCulled},
          {"clusters_pass1", st.clustersPass1},
          {"clusters_occlusion_tested", st.clustersOcclusionTested},
          {"clusters_occlusion_culled", st.clustersOcclusionCulled},
          {"instances_late", st.instancesLate},
          {"instances_occlusion_culled", st.instancesOcclusionCulled},
          {"history_kept", st.historyKept},
          {"clusters_drawn", st.clustersDrawn},
          {"clusters_hardware", st.clustersHardware},
          {"triangles_near_clipped", st.trianglesNearClipped},
          {"clusters_overflow", st.clustersOverflow},
          {"triangles_rasterized", st.trianglesRasterized},
          {"clusters_blend", st.clustersBlend},
          {"blend_raster", render::toString(st.blendRaster)},
          {"clusters_blend_hardware", st.clustersBlendHardware},
          {"oit_fragments", st.oitFragments},
          {"oit_pool_overflow", st.oitPoolOverflow},
          {"oit_layers_dropped", st.oitLayersDropped},
          {"pvs", st.pvs},
          {"instances_pvs_culled", st.instancesPvsCulled},
          {"clusters_pvs_culled", st.clustersPvsCulled},
          {"surfel_instances", st.surfels.visibleInstances},
          {"surfel_instances_fading", st.surfels.fadingInstances},
          {"surfels_splatted", st.surfels.surfelsSplatted}};
}

void printStats(const render::ClusterStats& st, const std::vector<gpu::PassTime>& times, bool median) {
  fmt::print("raster {}  selection {} ({} passes)  instances visible {}  nodes tested {}  clusters tested {}  "
             "selected {}  frustum-culled {}  cone-culled {}{}\n",
             render::toString(st.raster), render::toString(st.selection), st.selectionPasses, st.instancesVisible,
             st.nodesTested, st.clustersTested, st.clustersSelected, st.clustersFrustumCulled,
             st.clustersBackfaceCulled, st.clustersOverflow ? fmt::format("  OVERFLOW {}", st.clustersOverflow) : "");
  if (st.occlusion)
    fmt::print("occlusion: pass 1 drew {} clusters (visible last frame); pass 2 tested {} instances, culled {}, "
               "tested {} clusters, culled {}; {} clusters own pixels\n",
               st.clustersPass1, st.instancesLate, st.instancesOcclusionCulled, st.clustersOcclusionTested,
               st.clustersOcclusionCulled, st.historyKept);
  fmt::print("clusters drawn {} ({} by hardware)  triangles rasterized {}  near-clipped {}\n", st.clustersDrawn,
             st.clustersHardware, st.trianglesRasterized, st.trianglesNearClipped);
  if (st.clustersBlend)
    fmt::print("blend ({} raster): {} clusters ({} by hardware)  {} fragments  dropped: {} past the node pool, {} "
               "past 16 layers per pixel\n",
               render::toString(st.blendRaster), st.clustersBlend, st.clustersBlendHardware, st.oitFragments,
               st.oitPoolOverflow, st.oitLayersDropped);
  if (st.pvs)
    fmt::print("cell PVS: {} instances and {} cut clusters culled\n", st.instancesPvsCulled, st.clustersPvsCulled);
  if (st.surfels.visibleInstances || st.surfels.surfelsSplatted)
    fmt::print("surfels: {} instances ({} in the blend band)  surfels splatted {}\n", st.surfels.visibleInstances,
               st.surfels.fadingInstances, st.surfels.surfelsSplatted);
  for (const auto& t : times) fmt::print("gpu {:<8} {:9.3f} ms{}\n", t.name, t.milliseconds, median ? " (median)" : "");
}

uint64_t sourceTriangles(const lod::LodAsset& a) {
  uint64_t n = 0;
  for (const Instance& inst : a.scene.instances)
    if (inst.mesh < a.dags.size()) n += a.dags[inst.mesh].inputTriangles;
  return n;
}

} // namespace

void addLodCullOptions(CLI::App& command, LodCullOptions& o, bool bench) {
  command
      .add_option("--hybrid-threshold", o.hybridThreshold,
                  ".mrg, hybrid raster: clusters whose estimated triangle edge reaches this many pixels go to the "
                  "hardware path")
      ->capture_default_str();
  command
      .add_option("--occlusion", o.occlusion,
                  bench
                      ? ".mrg: two-pass HZB occlusion culling on|off|both (off: it cost more than it saved on the H200)"
                      : ".mrg: two-pass HZB occlusion culling on|off (off: it cost more than it saved on the H200)")
      ->capture_default_str();
  command.add_option("--cones", o.cones, ".mrg: normal-cone back-face culling on|off")->capture_default_str();
  command
      .add_option("--blend-raster", o.blendRaster,
                  bench ? ".mrg, alpha BLEND clusters: auto (hybrid), compute, hybrid, hardware, or all "
                          "(each, timed as 'blend')"
                        : ".mrg, alpha BLEND clusters: auto (hybrid), compute, hybrid or hardware")
      ->capture_default_str();
  command
      .add_option("--selection", o.selection,
                  bench ? ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of the "
                          "kept levels), hierarchy (BVH over groups), dag (tree of the DAG's groups) or all"
                        : ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of the "
                          "kept levels), hierarchy (BVH over groups) or dag (tree of the DAG's groups)")
      ->capture_default_str();
}

bool isLodAssetPath(const std::string& input) { return input.size() > 4 && input.ends_with(".mrg"); }

bool mrgHasClusterDags(const std::string& input) { return mrgContents(input).clusterDags; }

MrgContents mrgContents(const std::string& input) {
  MrgContents m;
  if (!isLodAssetPath(input)) return m;
  auto reader = asset::AssetReader::open(input);
  if (!reader) return m; // the loader reports the error
  m.clusterDags = reader->find(asset::chunk::ClusterDag).has_value();
  m.surfels = reader->find(asset::chunk::Surfels).has_value();
  m.pvs = reader->find(asset::chunk::Visibility).has_value();
  m.scene = reader->find(asset::chunk::Scene).has_value();
  return m;
}

void runLodRender(const LodRenderRequest& r) {
  if (r.frames < 1 || r.frames > 10000) return fail("--repeat must be in 1..10000");
  auto backend = render::parseRasterBackend(r.raster);
  if (!backend) return fail(backend.error());
  Session s;
  if (!open(r, /*needOutput=*/true, s)) return;
  s.settings.raster = *backend;
  Timed t;
  if (!s.path.empty()) {
    // One image per camera (plus a warm-up); on any error the images already written are removed.
    if (!r.exr.empty()) return fail("--exr is not supported with --path");
    std::vector<std::string> written;
    auto removeWritten = [&] {
      std::error_code ec;
      for (const auto& f : written) std::filesystem::remove(f, ec);
    };
    bool ok = renderFrames(s, int(s.path.size()) + 1, t, [&](const render::ClusterRenderOutput& o, size_t i) {
      std::string name = pathFrameName(r.output, i);
      if (auto st = io::writePng(name, o.image.srgb); !st) return fail(st.error()), false;
      written.push_back(name);
      return true;
    });
    if (!ok) return removeWritten();
    fmt::print("rendered {} cameras of {} -> {} .. {}; GPU frame median {:.3f} ms, max {:.3f} ms\n", s.path.size(),
               r.path, written.front(), written.back(), frameMilliseconds(t.times), t.maxFrameMs);
    if (r.stats) printStats(t.last.stats, t.times, true);
    return;
  }
  if (!renderFrames(s, r.frames, t)) return;
  if (auto st = io::writePng(r.output, t.last.image.srgb); !st) return fail(st.error());
  if (!r.exr.empty()) {
    auto st =
        r.exr.ends_with(".pfm") ? io::writePfm(r.exr, t.last.image.linear) : io::writeExr(r.exr, t.last.image.linear);
    if (!st) return fail(st.error());
  }
  const auto& caps = s.ctx->caps();
  if (r.json) {
    nlohmann::json j = statsJson(t.last.stats);
    j["input"] = r.input;
    j["output"] = r.output;
    j["device"] = caps.name;
    j["tau_pixels"] = r.tau;
    j["hybrid_threshold"] = r.cull.hybridThreshold;
    j["width"] = s.settings.base.width;
    j["height"] = s.settings.base.height;
    j["source_triangles"] = sourceTriangles(s.asset);
    j["load_seconds"] = s.loadSeconds;
    j["frames_timed"] = t.frames;
    if (!s.pvsPath.empty()) { // -1: the camera is in no view cell (no PVS culling)
      j["pvs_cell"] = s.pvsCell;
      j["pvs_bytes"] = s.pvsCell >= 0 ? s.clusterPvs.bytes() : 0;
    }
    for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} source triangles, {} instances, {} clusters) at {}x{}, tau {} px, on {} -> {}\n", r.input,
             sourceTriangles(s.asset), s.asset.scene.instances.size(), s.renderer->clusterCount(),
             s.settings.base.width, s.settings.base.height, r.tau, caps.name, r.output);
  if (r.stats) {
    fmt::print("load {:.3f} s\n", s.loadSeconds);
    printStats(t.last.stats, t.times, t.frames > 1);
  }
}

void runLodBench(const LodRenderRequest& r) {
  if (r.frames < 2 || r.frames > 100000) return fail("--frames must be in 2..100000");
  std::vector<render::RasterBackend> backends;
  if (r.raster != "all") {
    auto b = render::parseRasterBackend(r.raster);
    if (!b) return fail(b.error());
    backends.push_back(*b);
  }
  Session s;
  if (!open(r, /*needOutput=*/false, s)) return;
  s.settings.base.readImage = false; // no CPU gaps between timed frames (they lower the GPU clock)
  // On a path every camera is timed once (after a warm-up), whatever --frames says.
  int frames = s.path.empty() ? r.frames : int(s.path.size()) + 1;
  const auto& caps = s.ctx->caps();
  if (backends.empty()) {
    backends.push_back(render::RasterBackend::Indirect);
    if (caps.meshShader) backends.push_back(render::RasterBackend::Mesh);
    if (caps.int64BufferAtomics) backends.push_back(render::RasterBackend::Compute);
    if (caps.int64BufferAtomics && caps.fragmentStoresAndAtomics && caps.meshShader)
      backends.push_back(render::RasterBackend::Hybrid);
  }
  // --blend-raster all: every blend raster the device has, per opaque backend (scenes with BLEND
  // materials; the others draw no blend pass, so one run each).
  std::vector<render::BlendRaster> blends{s.settings.blendRaster};
  bool hasBlend = std::any_of(s.asset.scene.materials.begin(), s.asset.scene.materials.end(),
                              [](const Material& m) { return m.alphaMode == AlphaMode::Blend; });
  if (r.cull.blendRaster == "all" && hasBlend) {
    blends = {render::BlendRaster::Compute};
    if (caps.fragmentStoresAndAtomics)
      blends.insert(blends.end(), {render::BlendRaster::Hybrid, render::BlendRaster::Hardware});
  }
  std::vector<bool> occlusionModes;
  if (r.cull.occlusion != "off") occlusionModes.push_back(true);
  if (r.cull.occlusion != "on") occlusionModes.push_back(false);
  std::vector<render::SelectionMode> selections{s.settings.selection};
  if (r.cull.selection == "all")
    selections = {render::SelectionMode::Flat, render::SelectionMode::Hierarchy, render::SelectionMode::Dag};
  nlohmann::json all = nlohmann::json::array();
  double bestLodMs = INFINITY;
  if (!r.json)
    fmt::print("bench render {} on {}: {} source triangles, {} instances at {}x{}, tau {} px, hybrid threshold {} "
               "px, cones {}, selection {}, {} timed frames\n",
               r.input, caps.name, sourceTriangles(s.asset), s.asset.scene.instances.size(), s.settings.base.width,
               s.settings.base.height, r.tau, r.cull.hybridThreshold, r.cull.cones, r.cull.selection, frames - 1);
  for (render::RasterBackend b : backends)
    for (render::BlendRaster blend : blends)
      for (bool occlusion : occlusionModes)
        for (render::SelectionMode selection : selections) {
          s.settings.raster = b;
          s.settings.blendRaster = blend;
          s.settings.occlusionCulling = occlusion;
          s.settings.selection = selection;
          s.settings.pvsCulling = true;
          Timed t; // the untimed warm-up frame fills the occlusion history for this view
          if (!renderFrames(s, frames, t, r.warmupMs)) return;
          bestLodMs = std::min(bestLodMs, frameMilliseconds(t.times));
          // --pvs: the same frames again without the PVS, in this run (same clocks, same cameras).
          Timed off;
          if (!s.pvsPath.empty()) {
            s.settings.pvsCulling = false;
            if (!renderFrames(s, frames, off, r.warmupMs)) return;
          }
          if (r.json) {
            nlohmann::json j = statsJson(t.last.stats);
            for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
            j["gpu_ms_max_frame"] = t.maxFrameMs;
            if (!s.pvsPath.empty()) {
              j["triangles_mean"] = t.meanTriangles;
              j["pvs_frames_outside_cells"] = t.framesOutsideCells;
              j["without_pvs"] = {{"gpu_ms_frame", frameMilliseconds(off.times)},
                                  {"gpu_ms_max_frame", off.maxFrameMs},
                                  {"triangles_mean", off.meanTriangles}};
              for (const auto& p : off.times) j["without_pvs"]["gpu_ms"][p.name] = p.milliseconds;
            }
            all.push_back(j);
            continue;
          }
          fmt::print("-- {}{}, occlusion {}{}{}\n", render::toString(b),
                     t.last.stats.clustersBlend || blends.size() > 1
                         ? fmt::format(", blend {}", render::toString(t.last.stats.blendRaster))
                         : "",
                     occlusion ? "on" : "off",
                     selections.size() > 1 ? fmt::format(", selection {}", render::toString(selection)) : "",
                     s.pvsPath.empty() ? "" : ", cell PVS on");
          printStats(t.last.stats, t.times, true);
          if (!s.path.empty()) fmt::print("path {} cameras: slowest frame {:.3f} ms\n", s.path.size(), t.maxFrameMs);
          if (!s.pvsPath.empty()) {
            double on = frameMilliseconds(t.times), without = frameMilliseconds(off.times);
            fmt::print("PVS on : frame {:.3f} ms (median), {:.0f} triangles, {:.1f} instances + {:.1f} cut clusters "
                       "culled by the PVS per frame{}\n",
                       on, t.meanTriangles, t.meanPvsInstances, t.meanPvsClusters,
                       t.framesOutsideCells
                           ? fmt::format(" ({} frames outside every cell: not culled)", t.framesOutsideCells)
                           : "");
            fmt::print("PVS off: frame {:.3f} ms (median), {:.0f} triangles\n", without, off.meanTriangles);
            fmt::print("PVS speed-up {:.2f}x, triangles {:.1f}% of the unculled frame\n", without / std::max(on, 1e-9),
                       100.0 * t.meanTriangles / std::max(off.meanTriangles, 1.0));
          }
        }
  nlohmann::json baselines = nlohmann::json::array();
  if (r.baselines) {
    // Brute force at full resolution can take seconds per frame on big grids: few frames.
    auto b = renderLodBaselines(*s.ctx, s.asset, s.settings.base, r.tau, std::min(frames, 3));
    if (!b) return fail(b.error());
    for (const BaselineResult& x : *b) {
      if (r.json) {
        baselines.push_back({{"name", x.name},
                             {"gpu_ms_frame", x.frameMs},
                             {"triangles", x.triangles},
                             {"chain_levels", x.chainLevels},
                             {"instances_per_level", x.usage},
                             {"slower_than_cluster_lod", x.frameMs / bestLodMs}});
        continue;
      }
      fmt::print("-- {} (forward renderer{})\n", x.name, s.path.empty() ? "" : ", first camera of the path");
      fmt::print("gpu frame {:9.3f} ms  triangles {}  = {:.1f}x the best cluster-LOD frame\n", x.frameMs, x.triangles,
                 x.frameMs / bestLodMs);
      if (x.chainLevels)
        fmt::print("chain {} levels, instances per level {}\n", x.chainLevels, fmt::join(x.usage, " "));
    }
  }
  if (r.json) {
    nlohmann::json j = {{"bench", "render_lod"},
                        {"baselines", baselines},
                        {"input", r.input},
                        {"device", caps.name},
                        {"tau_pixels", r.tau},
                        {"hybrid_threshold", r.cull.hybridThreshold},
                        {"backends", all},
                        {"width", s.settings.base.width},
                        {"height", s.settings.base.height},
                        {"source_triangles", sourceTriangles(s.asset)}};
    fmt::print("{}\n", j.dump(2));
  }
}

} // namespace mirage::cli
