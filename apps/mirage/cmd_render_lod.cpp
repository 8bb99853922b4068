// mirage render / bench render on .mrg assets: runtime::Scene's cluster-LOD path, timed and printed.
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
#include "lod_progress.h"
#include "lod_render.h"
#include "mirage/io/image_io.h"
#include "mirage/particles/render.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/runtime/frame_time.h"
#include "mirage/runtime/scene.h"
#include "mirage/runtime/scene_argument.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct Session {
  std::unique_ptr<gpu::Context> ctx;
  std::unique_ptr<runtime::Scene> scene;
  runtime::View view;
  std::vector<render::Camera> path;                // --path: frame i uses path[i % size]
  std::unique_ptr<particles::EffectPlayer> effect; // --particles
  std::chrono::steady_clock::time_point opened;    // just before the scene was opened
};

// Makes the view cell holding `eye` current and, unless `quiet`, says which one it is. Returns
// false after fail().
bool selectPvsCell(Session& s, glm::vec3 eye, bool quiet) {
  auto changed = s.scene->selectPvsCell(eye);
  if (!changed) return fail(changed.error()), false;
  if (!*changed || quiet) return true;
  const runtime::PvsState& p = s.scene->pvs();
  if (p.cell < 0)
    fmt::print("PVS: the camera at ({:.4g}, {:.4g}, {:.4g}) is in none of the {} view cells: no PVS culling\n", eye.x,
               eye.y, eye.z, p.cells);
  else
    fmt::print("PVS: cell {} of {}: {} triangles -> {} of {} instances, {} (instance, cluster) pairs visible; "
               "{} bytes uploaded, made in {:.2f} ms\n",
               p.cell, p.cells, p.cellTriangles, p.visibleInstances, s.scene->info().instances, p.visibleClusters,
               p.bytes, p.milliseconds);
  return true;
}

// Cameras at every view cell's centre looking four ways (as `bench pvs`).
std::vector<render::Camera> cellCameras(const vis::PvsData& pvs) {
  std::vector<render::Camera> cams;
  for (const vis::ViewCell& cell : pvs.cells)
    for (const render::Camera& c : runtime::cellViewCameras(cell)) cams.push_back(c);
  return cams;
}

// Checks the arguments, starts the GPU, opens the scene. Returns false after fail().
bool open(const LodRenderRequest& r, bool needOutput, Session& s) {
  if (auto st = parseSize(r.size, s.view.width, s.view.height); !st) return fail(st.error()), false;
  if (needOutput) {
    if (auto st = checkOutputPath(r.output, {".png"}); !st) return fail(st.error()), false;
    if (!r.exr.empty())
      if (auto st = checkOutputPath(r.exr, {".exr", ".pfm"}); !st) return fail(st.error()), false;
  }
  if (auto st = runtime::validate(r.config); !st) return fail(st.error()), false;
  if (r.stereoIpd)
    if (auto st = render::validateIpd(*r.stereoIpd); !st) return fail(st.error()), false;
  render::Camera camera;
  if (!r.camera.empty()) {
    auto c = render::parseCamera(r.camera);
    if (!c) return fail(c.error()), false;
    camera = *c;
  }
  auto ctx = openDevice(r.device);
  if (!ctx) return fail(ctx.error()), false;
  s.ctx = std::move(*ctx);
  s.opened = std::chrono::steady_clock::now();
  auto scene = runtime::Scene::open(*s.ctx, r.scene);
  if (!scene) return fail(scene.error()), false;
  s.scene = std::move(*scene);
  float aspect = float(s.view.width) / float(s.view.height);
  s.view.camera = r.camera.empty() ? render::autoCamera(s.scene->bounds(), aspect) : camera;
  if (!r.path.empty()) {
    if (!r.camera.empty()) return fail("give --camera or --path, not both"), false;
    auto path = render::cameraPathArgument(r.path, s.scene->bounds(), aspect);
    if (!path) return fail(path.error()), false;
    s.path = std::move(*path);
    s.view.camera = s.path[0];
  }
  s.view.readLinear = !r.exr.empty();
  s.view.config = r.config;
  s.view.stereoIpd = r.stereoIpd;
  if (!r.particles.empty()) { // the effect drawn with the scene, inside the clip planes of both
    auto sim = parseNamed(r.particleSim, "--particle-sim", particles::kSimKindNames);
    if (!sim) return fail(sim.error()), false;
    auto played = particles::playEffect(*s.ctx, r.particles, r.particleFrames, *sim, 1.0f / 60.0f);
    if (!played) return fail(played.error()), false;
    s.effect = std::move(*played);
    s.view.particles = s.effect->draw();
    if (!r.particleSplat) (void)s.view.particles->setSettings({0.0f}); // billboards only (a valid setting)
    Bounds fx = s.effect->bounds();
    s.view.camera = particles::clipAround(s.view.camera, s.scene->bounds(), fx);
    for (render::Camera& c : s.path) c = particles::clipAround(c, s.scene->bounds(), fx);
  }
  if (const vis::PvsData* pvs = s.scene->pvsData()) {
    if (!needOutput && r.camera.empty() && r.path.empty()) { // bench: views from every cell
      s.path = cellCameras(*pvs);
      s.view.camera = s.path[0];
    }
    if (!selectPvsCell(s, s.view.camera.eye, /*quiet=*/r.json || !s.path.empty())) return false;
  }
  return true;
}

struct Timed {
  std::vector<gpu::PassTime> times; // medians over the timed frames
  runtime::Frame last;
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
    if (!s.path.empty()) s.view.camera = s.path[cameraIndex % s.path.size()];
    if (!selectPvsCell(s, s.view.camera.eye, /*quiet=*/s.path.size() > 1)) return false;
    auto o = s.scene->render(s.view);
    if (!o) return fail(o.error()), false;
    if (i == 0 && frames > 1 &&
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() < warmupMs) {
      --i; // still warming up: this frame again
      continue;
    }
    all.push_back(o->passTimes);
    if (i > 0 || frames == 1) {
      if (!onFrame(*o, cameraIndex)) return false;
      out.meanTriangles += double(o->trianglesDrawn);
      out.meanPvsInstances += o->cluster->instancesPvsCulled;
      out.meanPvsClusters += o->cluster->clustersPvsCulled;
      out.framesOutsideCells += s.scene->pvs().active && s.scene->pvs().cell < 0;
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
      s, frames, out, [](const runtime::Frame&, size_t) { return true; }, warmupMs);
}

} // namespace

nlohmann::json residencyTimesJson(const render::ResidencyTimes& t, std::optional<double> wallMs) {
  nlohmann::json j = {{"take_ms", t.takeMs},
                      {"upload_ms", t.uploadMs},
                      {"prefetch_ms", t.prefetchMs},
                      {"step_ms", t.stepMs},
                      {"request_ms", t.requestMs},
                      {"publish_ms", t.publishMs},
                      {"setup_ms", t.setupMs},
                      {"submit_wait_ms", t.submitMs},
                      {"collect_ms", t.collectMs},
                      {"readback_ms", t.readbackMs},
                      {"read_wait_ms", t.readWaitMs},
                      {"render_thread_ms", t.renderThreadMs()},
                      {"decode_threads_ms", t.decodeMs},
                      {"layout_threads_ms", t.layoutMs}};
  if (wallMs) j["other_ms"] = *wallMs - t.renderThreadMs();
  return j;
}

std::string residencyTimesText(const render::ResidencyTimes& t) {
  return fmt::format("take {:.2f}, upload {:.2f}, prefetch {:.2f}, step {:.2f}, request {:.2f}, publish {:.2f}, "
                     "setup {:.2f}, submit+wait {:.2f}, collect {:.2f}, readback {:.2f}, read wait {:.2f} ms; "
                     "reading and decoding {:.2f} ms, layout {:.2f} ms on the reader threads",
                     t.takeMs, t.uploadMs, t.prefetchMs, t.stepMs, t.requestMs, t.publishMs, t.setupMs, t.submitMs,
                     t.collectMs, t.readbackMs, t.readWaitMs, t.decodeMs, t.layoutMs);
}

namespace {

nlohmann::json residencyJson(const render::ResidencyStats& r) {
  return {{"requested", r.requested},
          {"loaded", r.loaded},
          {"uploaded", r.uploaded},
          {"evicted", r.evicted},
          {"unfit", r.unfit},
          {"pending", r.pending},
          {"in_transit", r.inTransit},
          {"resident_bytes", r.residentBytes},
          {"geometry_bytes", r.geometryBytes},
          {"resident_pages", r.residentPages},
          {"drawn_pages", r.drawnPages},
          {"bytes_read", r.bytesRead},
          {"bytes_received", r.bytesReceived},
          {"cpu_ms", residencyTimesJson(r.times)}};
}

// GPU residency (--gpu-budget): the last frame's figures; with a converged render the frames it took.
void addResidencyJson(nlohmann::json& j, const runtime::Frame& f) {
  const render::ResidencyStats& r = f.cluster->residency;
  if (!r.enabled) return;
  j["gpu_budget"] = r.budgetBytes;
  j["resident_bytes"] = r.residentBytes;
  j["resident_pages"] = r.residentPages;
  j["pages"] = r.pages;
  j["pool_bytes"] = r.poolBytes;
  j["unit_bytes"] = r.unitBytes;
  j["geometry_bytes"] = r.geometryBytes;
  j["record_bytes"] = r.recordBytes;
  j["cluster_table_bytes"] = r.clusterTableBytes;
  j["tree_node_bytes"] = r.treeNodeBytes;
  j["bytes_received"] = r.bytesReceived;
  j["bytes_read"] = r.bytesRead;
  j["pages_requested"] = r.requested;
  j["pages_uploaded"] = r.uploaded;
  j["pages_evicted"] = r.evicted;
  if (!f.residency) return;
  j["frames_to_converge"] = f.residency->framesToConverge;
  j["residency_converged"] = f.residency->converged;
  render::ResidencyTimes sum; // every frame of the converged render, the final one too
  for (const render::ResidencyStats& s : f.residency->frames) sum += s.times;
  j["residency_cpu_ms"] = residencyTimesJson(sum);
  nlohmann::json frames = nlohmann::json::array();
  for (const render::ResidencyStats& s : f.residency->frames) frames.push_back(residencyJson(s));
  j["residency_frames"] = frames;
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
          {"clusters_lean", st.clustersLean},
          {"triangles_near_clipped", st.trianglesNearClipped},
          {"clusters_overflow", st.clustersOverflow},
          {"triangles_rasterized", st.trianglesRasterized},
          {"clusters_blend", st.clustersBlend},
          {"blend_raster", render::toString(st.blendRaster)},
          {"stereo_mode", st.stereoMode == render::StereoMode::Auto ? "mono" : render::toString(st.stereoMode)},
          {"clusters_blend_hardware", st.clustersBlendHardware},
          {"blend_queue_triangles", st.blendQueueTriangles},
          {"blend_queue_tiles", st.blendQueueTiles},
          {"blend_queue_overflow", st.blendQueueOverflow},
          {"oit_fragments", st.oitFragments},
          {"oit_pool_overflow", st.oitPoolOverflow},
          {"oit_layers_dropped", st.oitLayersDropped},
          {"oit_dropped", uint64_t(st.oitPoolOverflow) + st.oitLayersDropped},
          {"msl", st.msl},
          {"oit_fixed_slots", st.oitFixedSlots},
          {"oit_fixed_redone", st.oitFixedRedone},
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
  fmt::print("clusters drawn {} ({} by hardware, {} by the lean raster)  triangles rasterized {}  near-clipped {}\n",
             st.clustersDrawn, st.clustersHardware, st.clustersLean, st.trianglesRasterized, st.trianglesNearClipped);
  if (st.clustersBlend)
    fmt::print("blend ({} raster): {} clusters ({} by hardware)  {} fragments  msl {:.3f}  oit_dropped {}: {} past "
               "the node pool (the farthest), {} past 16 layers per pixel\n",
               render::toString(st.blendRaster), st.clustersBlend, st.clustersBlendHardware, st.oitFragments, st.msl,
               uint64_t(st.oitPoolOverflow) + st.oitLayersDropped, st.oitPoolOverflow, st.oitLayersDropped);
  if (st.oitFixedSlots)
    fmt::print("transparency in {} fixed slots per pixel{}\n", st.oitFixedSlots,
               st.oitFixedRedone ? ": a pixel had more fragments, placed again as packed ranges" : "");
  if (st.blendQueueTriangles || st.blendQueueOverflow)
    fmt::print("blend queue: {} large triangles, {} tiles of 8x8 pixels{}\n", st.blendQueueTriangles,
               st.blendQueueTiles,
               st.blendQueueOverflow ? fmt::format("  FULL: {} walked by their cluster", st.blendQueueOverflow) : "");
  if (st.pvs)
    fmt::print("cell PVS: {} instances and {} cut clusters culled\n", st.instancesPvsCulled, st.clustersPvsCulled);
  if (st.residency.enabled)
    fmt::print("residency: {} of {} pages resident, {} of {} bytes ({} of geometry, units of {} bytes), {} bytes "
               "read; this frame {} requested, {} loaded, {} uploaded, {} evicted, {} pending\n",
               st.residency.residentPages, st.residency.pages, st.residency.residentBytes, st.residency.budgetBytes,
               st.residency.geometryBytes, st.residency.unitBytes, st.residency.bytesRead, st.residency.requested,
               st.residency.loaded, st.residency.uploaded, st.residency.evicted, st.residency.pending);
  if (st.surfels.visibleInstances || st.surfels.surfelsSplatted)
    fmt::print("surfels: {} instances ({} in the blend band)  surfels splatted {}\n", st.surfels.visibleInstances,
               st.surfels.fadingInstances, st.surfels.surfelsSplatted);
  for (const auto& t : times) fmt::print("gpu {:<8} {:9.3f} ms{}\n", t.name, t.milliseconds, median ? " (median)" : "");
}

// --- bench render --target-ms ------------------------------------------------------------------
// The frame-time controller (runtime/frame_time.h) picks each frame's tau and surfel size from the
// previous frames' GPU times. Bench frames are waited for, so frame i's time steers frame i + 1.
struct TargetRow {
  size_t camera = 0;
  float tau = 0.0f, surfelSize = 0.0f;
  double gpuMs = 0.0;
  uint64_t triangles = 0;
};

void runFrameTimeBench(Session& s, const LodRenderRequest& r) {
  const runtime::FrameTimeSettings& ft = *r.frameTime;
  runtime::RenderConfig& config = s.view.config;
  runtime::FrameTimeState state = runtime::startFrameTime(ft, config);
  runtime::applyFrameTime(ft, state, config);
  // Untimed warm-up at the starting tau (not fed: an idle GPU's clock is still rising).
  auto start = std::chrono::steady_clock::now();
  std::string raster;
  do {
    auto o = s.scene->render(s.view);
    if (!o) return fail(o.error());
    raster = render::toString(o->cluster->raster);
  } while (std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() < r.warmupMs);
  size_t timed = s.path.empty() ? size_t(r.frames - 1) : s.path.size();
  std::vector<TargetRow> rows;
  for (size_t i = 0; i < timed; ++i) {
    size_t camera = s.path.empty() ? 0 : i % s.path.size();
    if (!s.path.empty()) s.view.camera = s.path[camera];
    if (!selectPvsCell(s, s.view.camera.eye, /*quiet=*/true)) return;
    runtime::applyFrameTime(ft, state, config);
    auto o = s.scene->render(s.view);
    if (!o) return fail(o.error());
    double ms = frameMilliseconds(o->passTimes);
    rows.push_back({camera, config.tauPixels, config.surfelSize, ms, o->trianglesDrawn});
    runtime::updateFrameTime(ft, state, config.tauPixels, ms);
  }
  size_t within = 0;
  std::vector<double> times;
  for (const TargetRow& row : rows) {
    within += std::abs(row.gpuMs - ft.targetMs) <= 0.1 * ft.targetMs;
    times.push_back(row.gpuMs);
  }
  std::sort(times.begin(), times.end());
  double median = times.empty() ? 0.0 : times[times.size() / 2];
  double share = rows.empty() ? 0.0 : double(within) / double(rows.size());
  const runtime::SceneInfo& info = s.scene->info();
  if (r.json) {
    nlohmann::json frames = nlohmann::json::array();
    for (const TargetRow& row : rows)
      frames.push_back({{"camera", row.camera},
                        {"tau_pixels", row.tau},
                        {"surfel_size", row.surfelSize},
                        {"gpu_ms_frame", row.gpuMs},
                        {"triangles", row.triangles}});
    nlohmann::json j = {{"bench", "render_lod_target"},
                        {"input", r.scene.input},
                        {"device", s.ctx->caps().name},
                        {"width", s.view.width},
                        {"height", s.view.height},
                        {"source_triangles", info.sourceTriangles},
                        {"raster", raster},
                        {"target_ms", ft.targetMs},
                        {"tau_min", ft.tauMin},
                        {"tau_max", ft.tauMax},
                        {"frames", frames},
                        {"frames_within_10_percent", within},
                        {"share_within_10_percent", share},
                        {"gpu_ms_median", median}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench render {} on {}: {} source triangles, {} instances at {}x{}, raster {}, target {} ms (tau {}..{} "
             "px), {} timed frames\n",
             r.scene.input, s.ctx->caps().name, info.sourceTriangles, info.instances, s.view.width, s.view.height,
             raster, ft.targetMs, ft.tauMin, ft.tauMax, rows.size());
  for (size_t i = 0; i < rows.size(); ++i)
    fmt::print("frame {:4}  camera {:4}  tau {:6.2f} px  surfel {:5.2f} px  gpu {:9.3f} ms  triangles {}\n", i,
               rows[i].camera, rows[i].tau, rows[i].surfelSize, rows[i].gpuMs, rows[i].triangles);
  fmt::print("target {} ms: {} of {} frames within +-10 % ({:.1f} %), median gpu frame {:.3f} ms\n", ft.targetMs,
             within, rows.size(), 100.0 * share, median);
}

} // namespace

void runLodRender(const LodRenderRequest& r) {
  if (r.frames < 1 || r.frames > 10000) return fail("--repeat must be in 1..10000");
  if (!r.progressJson.empty()) {
    if (r.scene.gpuBudget == 0) return fail("--progress-json needs --gpu-budget (a paged .mrg streamed in)");
    if (r.frames != 1 || !r.path.empty()) return fail("--progress-json records one image: no --repeat or --path");
    if (auto st = checkOutputPath(r.progressJson, {".json"}); !st) return fail(st.error());
  }
  Session s;
  if (!open(r, /*needOutput=*/true, s)) return;
  s.view.readEveryFrame = !r.progressJson.empty();
  Timed t;
  if (!s.path.empty()) {
    // One image per camera (plus a warm-up); on any error the images already written are removed.
    if (!r.exr.empty()) return fail("--exr is not supported with --path");
    std::vector<std::string> written;
    auto removeWritten = [&] {
      std::error_code ec;
      for (const auto& f : written) std::filesystem::remove(f, ec);
    };
    bool ok = renderFrames(s, int(s.path.size()) + 1, t, [&](const runtime::Frame& o, size_t i) {
      std::string name = render::pathFrameName(r.output, i);
      if (auto st = io::writePng(name, o.srgb); !st) return fail(st.error()), false;
      written.push_back(name);
      return true;
    });
    if (!ok) return removeWritten();
    fmt::print("rendered {} cameras of {} -> {} .. {}; GPU frame median {:.3f} ms, max {:.3f} ms\n", s.path.size(),
               r.path, written.front(), written.back(), frameMilliseconds(t.times), t.maxFrameMs);
    if (r.stats) printStats(*t.last.cluster, t.times, true);
    return;
  }
  if (!renderFrames(s, r.frames, t)) return;
  if (!r.progressJson.empty()) {
    if (!t.last.residency) return fail(r.scene.input + ": no streamed frames to report (needs a paged .mrg)");
    auto st = writeProgressJson(r.progressJson, r.scene.input, r.scene.source.bandwidthBitsPerSecond, *t.last.residency,
                                s.opened);
    if (!st) return fail(st.error());
  }
  if (auto st = io::writePng(r.output, t.last.srgb); !st) return fail(st.error());
  if (!r.exr.empty()) {
    auto st = r.exr.ends_with(".pfm") ? io::writePfm(r.exr, t.last.linear) : io::writeExr(r.exr, t.last.linear);
    if (!st) return fail(st.error());
  }
  const auto& caps = s.ctx->caps();
  const runtime::SceneInfo& info = s.scene->info();
  if (r.json) {
    nlohmann::json j = statsJson(*t.last.cluster);
    addResidencyJson(j, t.last);
    j["input"] = r.scene.input;
    j["output"] = r.output;
    j["device"] = caps.name;
    j["tau_pixels"] = r.config.tauPixels;
    j["hybrid_threshold"] = r.config.hybridThreshold;
    j["blend_queue_pixels"] = r.config.blendQueuePixels;
    j["width"] = s.view.width;
    j["height"] = s.view.height;
    if (r.stereoIpd) j["stereo_ipd"] = *r.stereoIpd; // the image is 2 * width wide, left|right
    if (r.config.debugView != render::DebugView::None) j["debug_view"] = render::toString(r.config.debugView);
    j["source_triangles"] = info.sourceTriangles;
    j["load_seconds"] = info.loadSeconds;
    j["frames_timed"] = t.frames;
    if (const runtime::PvsState& pvs = s.scene->pvs(); pvs.active) { // -1: the camera is in no view cell
      j["pvs_cell"] = pvs.cell;
      j["pvs_bytes"] = pvs.cell >= 0 ? pvs.bytes : 0;
    }
    for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} source triangles, {} instances, {} clusters) at {}x{}{}, tau {} px{}, on {} -> {}\n",
             r.scene.input, info.sourceTriangles, info.instances, info.clusters, s.view.width, s.view.height,
             r.stereoIpd ? fmt::format(" per eye (stereo, ipd {}: {}x{} left|right)", *r.stereoIpd, t.last.srgb.width,
                                       t.last.srgb.height)
                         : "",
             r.config.tauPixels,
             r.config.debugView != render::DebugView::None
                 ? fmt::format(", debug view {}", render::toString(r.config.debugView))
                 : "",
             caps.name, r.output);
  if (r.stats) {
    fmt::print("load {:.3f} s\n", info.loadSeconds);
    if (t.last.residency) {
      render::ResidencyTimes sum;
      for (const render::ResidencyStats& f : t.last.residency->frames) sum += f.times;
      fmt::print("residency {} after {} frames; CPU time of its {} frames: {}\n",
                 t.last.residency->converged ? "converged" : "NOT converged", t.last.residency->framesToConverge,
                 t.last.residency->frames.size(), residencyTimesText(sum));
    }
    printStats(*t.last.cluster, t.times, t.frames > 1);
  }
}

void runLodBench(const LodRenderRequest& r) {
  if (r.frames < 2 || r.frames > 100000) return fail("--frames must be in 2..100000");
  if (r.frameTime) {
    if (auto st = runtime::validate(*r.frameTime); !st) return fail(st.error());
    if (r.sweeps.allBlendRasters || r.sweeps.allSelections || r.sweeps.bothOcclusion || r.sweeps.bothLean ||
        r.baselines)
      return fail("--target-ms times one configuration: no all/both sweeps and no --baselines");
  }
  std::vector<render::RasterBackend> backends;
  if (!r.sweeps.allRasters) backends.push_back(r.config.raster);
  Session s;
  if (!open(r, /*needOutput=*/false, s)) return;
  s.view.readImage = false; // no CPU gaps between timed frames (they lower the GPU clock)
  if (r.frameTime) return runFrameTimeBench(s, r);
  if (r.scene.gpuBudget > 0 && !s.path.empty()) { // camera cuts: one configuration
    if (r.sweeps.allBlendRasters || r.sweeps.allSelections || r.sweeps.bothOcclusion || r.baselines || r.stereoIpd ||
        r.scene.pvs.size())
      return fail("--gpu-budget with --path times camera cuts in one configuration: no all/both sweeps, --baselines "
                  "or --stereo");
    if (r.sweeps.allRasters) s.view.config.raster = render::RasterBackend::Auto;
    return runCutBench(*s.ctx, *s.scene, s.view, s.path, r);
  }
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
  const runtime::SceneInfo& info = s.scene->info();
  bool withPvs = s.scene->pvs().active;
  runtime::RenderConfig& config = s.view.config;
  std::vector<render::BlendRaster> blends{config.blendRaster};
  if (r.sweeps.allBlendRasters && info.blendMaterials) {
    blends = {render::BlendRaster::Compute};
    if (caps.fragmentStoresAndAtomics)
      blends.insert(blends.end(), {render::BlendRaster::Hybrid, render::BlendRaster::Hardware});
  }
  std::vector<bool> occlusionModes;
  if (r.sweeps.bothOcclusion || config.occlusionCulling) occlusionModes.push_back(true);
  if (r.sweeps.bothOcclusion || !config.occlusionCulling) occlusionModes.push_back(false);
  std::vector<bool> leanModes;
  if (r.sweeps.bothLean || config.leanRaster) leanModes.push_back(true);
  if (r.sweeps.bothLean || !config.leanRaster) leanModes.push_back(false);
  std::vector<render::SelectionMode> selections{config.selection};
  if (r.sweeps.allSelections)
    selections = {render::SelectionMode::Flat, render::SelectionMode::Hierarchy, render::SelectionMode::Dag};
  nlohmann::json all = nlohmann::json::array();
  double bestLodMs = INFINITY;
  if (!r.json)
    fmt::print("bench render {} on {}: {} source triangles, {} instances at {}x{}, tau {} px, hybrid threshold {} "
               "px, cones {}, selection {}, {} timed frames{}{}\n",
               r.scene.input, caps.name, info.sourceTriangles, info.instances, s.view.width, s.view.height,
               config.tauPixels, config.hybridThreshold, config.coneCulling ? "on" : "off",
               r.sweeps.allSelections ? "all" : render::toString(config.selection), frames - 1,
               r.stereoIpd ? fmt::format(", stereo per eye (ipd {})", *r.stereoIpd) : "",
               config.debugView != render::DebugView::None
                   ? fmt::format(", debug view {}", render::toString(config.debugView))
                   : "");
  for (render::RasterBackend b : backends)
    for (render::BlendRaster blend : blends)
      for (bool occlusion : occlusionModes)
        for (render::SelectionMode selection : selections)
          for (bool lean : leanModes) {
            // --lean-raster both: the switch is the compute raster's (one run for the other backends).
            if (leanModes.size() > 1 && !lean && b != render::RasterBackend::Compute) continue;
            config.leanRaster = lean;
            config.raster = b;
            config.blendRaster = blend;
            config.occlusionCulling = occlusion;
            config.selection = selection;
            config.pvsCulling = true;
            Timed t; // the untimed warm-up frame fills the occlusion history for this view
            if (!renderFrames(s, frames, t, r.warmupMs)) return;
            bestLodMs = std::min(bestLodMs, frameMilliseconds(t.times));
            // --pvs: the same frames again without the PVS, in this run (same clocks, same cameras).
            Timed off;
            if (withPvs) {
              config.pvsCulling = false;
              if (!renderFrames(s, frames, off, r.warmupMs)) return;
              config.pvsCulling = true;
            }
            // --stereo: the same frames mono, one eye's size, in this run (same clocks, same cameras).
            Timed mono;
            if (r.stereoIpd) {
              s.view.stereoIpd.reset();
              bool ok = renderFrames(s, frames, mono, r.warmupMs);
              s.view.stereoIpd = r.stereoIpd;
              if (!ok) return;
            }
            double stereoRatio = frameMilliseconds(t.times) / std::max(frameMilliseconds(mono.times), 1e-9);
            if (r.json) {
              nlohmann::json j = statsJson(*t.last.cluster);
              j["lean_raster"] = lean && b == render::RasterBackend::Compute;
              addResidencyJson(j, t.last);
              for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
              j["gpu_ms_max_frame"] = t.maxFrameMs;
              if (r.stereoIpd) {
                j["stereo_ipd"] = *r.stereoIpd;
                j["mono"] = {{"gpu_ms_frame", frameMilliseconds(mono.times)}, {"triangles_mean", mono.meanTriangles}};
                for (const auto& p : mono.times) j["mono"]["gpu_ms"][p.name] = p.milliseconds; // pass by pass
                j["stereo_over_mono"] = stereoRatio;
              }
              if (withPvs) {
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
            fmt::print("-- {}{}{}, occlusion {}{}{}\n", render::toString(b),
                       b == render::RasterBackend::Compute && leanModes.size() > 1
                           ? fmt::format(", lean raster {}", lean ? "on" : "off")
                           : "",
                       t.last.cluster->clustersBlend || blends.size() > 1
                           ? fmt::format(", blend {}", render::toString(t.last.cluster->blendRaster))
                           : "",
                       occlusion ? "on" : "off",
                       selections.size() > 1 ? fmt::format(", selection {}", render::toString(selection)) : "",
                       withPvs ? ", cell PVS on" : "");
            printStats(*t.last.cluster, t.times, true);
            if (!s.path.empty()) fmt::print("path {} cameras: slowest frame {:.3f} ms\n", s.path.size(), t.maxFrameMs);
            if (r.stereoIpd) {
              fmt::print("stereo (ipd {}, {}): both eyes {:.3f} ms, {:.0f} triangles; mono one eye {:.3f} ms, {:.0f} "
                         "triangles; stereo/mono {:.2f}x\n",
                         *r.stereoIpd, render::toString(t.last.cluster->stereoMode), frameMilliseconds(t.times),
                         t.meanTriangles, frameMilliseconds(mono.times), mono.meanTriangles, stereoRatio);
              std::string passes; // the mono frame pass by pass, beside the stereo ones printed above
              for (const auto& p : mono.times) passes += fmt::format(" {} {:.3f}", p.name, p.milliseconds);
              fmt::print("mono passes (ms, median):{}\n", passes);
            }
            if (withPvs) {
              double on = frameMilliseconds(t.times), without = frameMilliseconds(off.times);
              fmt::print("PVS on : frame {:.3f} ms (median), {:.0f} triangles, {:.1f} instances + {:.1f} cut clusters "
                         "culled by the PVS per frame{}\n",
                         on, t.meanTriangles, t.meanPvsInstances, t.meanPvsClusters,
                         t.framesOutsideCells
                             ? fmt::format(" ({} frames outside every cell: not culled)", t.framesOutsideCells)
                             : "");
              fmt::print("PVS off: frame {:.3f} ms (median), {:.0f} triangles\n", without, off.meanTriangles);
              fmt::print("PVS speed-up {:.2f}x, triangles {:.1f}% of the unculled frame\n",
                         without / std::max(on, 1e-9), 100.0 * t.meanTriangles / std::max(off.meanTriangles, 1.0));
            }
          }
  nlohmann::json baselines = nlohmann::json::array();
  if (r.baselines) {
    // Brute force at full resolution can take seconds per frame on big grids: few frames.
    render::RenderSettings base;
    base.width = s.view.width;
    base.height = s.view.height;
    base.camera = s.view.camera;
    base.readImage = false;
    auto b = renderLodBaselines(*s.ctx, *s.scene->lodAsset(), base, config.tauPixels, std::min(frames, 3));
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
                        {"input", r.scene.input},
                        {"device", caps.name},
                        {"tau_pixels", config.tauPixels},
                        {"hybrid_threshold", config.hybridThreshold},
                        {"blend_queue_pixels", config.blendQueuePixels},
                        {"backends", all},
                        {"width", s.view.width},
                        {"height", s.view.height},
                        {"source_triangles", info.sourceTriangles}};
    fmt::print("{}\n", j.dump(2));
  }
}

} // namespace mirage::cli
