// `mirage bench render SCENE.mrg --gpu-budget SIZE --path P`: every camera of the path is a camera
// cut. Per camera: the frames from the cut until the residency asks for nothing more (the time to
// the first full-quality frame), then --frames frames at that camera timed on the GPU.
#include <algorithm>
#include <chrono>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lod_render.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

struct CutRow {
  size_t camera = 0;
  bool converged = false;
  uint32_t framesToFullQuality = 0;     // frames rendered until the first full-quality one, it included
  double secondsToFullQuality = 0;      // from the cut to the end of that frame
  double wallMsMaxConverging = 0;       // slowest frame (wall, synchronous) until then
  double gpuMsMaxConverging = 0;        // slowest frame on the GPU until then (uploads in it)
  double gpuMsMedian = 0, gpuMsMax = 0; // the timed frames at the converged residency
  uint64_t triangles = 0;
  uint64_t bytesRead = 0; // page bytes read because of this cut
  uint32_t pagesLoaded = 0, pagesEvicted = 0;
  uint32_t pagesMissing = 0; // pages the converged view still asks for (0: the budget held the full cut)
  uint64_t residentBytes = 0;
  render::ResidencyTimes times; // CPU time by phase, summed over the frames to full quality
};

} // namespace

void runCutBench(gpu::Context& ctx, runtime::Scene& scene, runtime::View view, const std::vector<render::Camera>& path,
                 const LodRenderRequest& r) {
  const int timedFrames = std::max(r.frames - 1, 1);
  // Warm-up (pipelines, clocks) looking straight up from above the scene: nothing in view, so
  // nothing is asked for and the first camera is a cut like the others.
  view.readImage = false;
  runtime::View sky = view;
  sky.camera = path[0];
  sky.camera.target = sky.camera.eye + glm::vec3(0.0f, 1.0f, 0.0f);
  sky.camera.up = glm::vec3(0.0f, 0.0f, 1.0f);
  auto start = Clock::now();
  do {
    auto o = scene.render(sky);
    if (!o) return fail(o.error());
  } while (seconds(start, Clock::now()) * 1e3 < r.warmupMs);

  std::vector<CutRow> rows;
  uint64_t readBefore = 0;
  uint64_t tableBytes = 0; // the GPU tables outside the budget: per cluster and the trees' nodes (ResidencyStats)
  for (size_t c = 0; c < path.size(); ++c) {
    CutRow row;
    row.camera = c;
    // The cut: frames (synchronous, as renderConverged runs them) until the residency is stable.
    runtime::View cut = view;
    cut.camera = path[c];
    cut.readImage = true;
    cut.cameraCut = true; // whatever the path's spacing
    auto t0 = Clock::now();
    auto f = scene.render(cut);
    if (!f) return fail(f.error());
    const runtime::Frame::Residency& res = *f->residency;
    // Frame k stepped on frame k - 1's feedback and found nothing to load, upload or wait for:
    // frame k - 1 drew the full cut (k >= 1). Its end is the first full-quality frame's.
    uint32_t k = std::max(res.framesToConverge, 1u);
    row.converged = res.converged;
    row.framesToFullQuality = k;
    row.secondsToFullQuality = seconds(t0, res.frameEnds[k - 1]);
    for (uint32_t i = 0; i < k; ++i)
      row.wallMsMaxConverging =
          std::max(row.wallMsMaxConverging, seconds(i ? res.frameEnds[i - 1] : t0, res.frameEnds[i]) * 1e3);
    for (uint32_t i = 0; i < k && i < res.frameGpuMs.size(); ++i)
      row.gpuMsMaxConverging = std::max(row.gpuMsMaxConverging, res.frameGpuMs[i]);
    for (const render::ResidencyStats& s : res.frames) row.pagesLoaded += s.loaded, row.pagesEvicted += s.evicted;
    for (uint32_t i = 0; i < k && i < res.frames.size(); ++i) row.times += res.frames[i].times;
    const render::ResidencyStats& last = f->cluster->residency;
    row.bytesRead = last.bytesRead - readBefore;
    readBefore = last.bytesRead;
    row.residentBytes = last.residentBytes;
    tableBytes = last.clusterTableBytes + last.treeNodeBytes;
    row.pagesMissing = last.requested;
    // The converged residency, timed on the GPU without readbacks.
    std::vector<double> ms;
    runtime::View timed = view;
    timed.camera = path[c];
    for (int i = 0; i < timedFrames; ++i) {
      auto o = scene.render(timed);
      if (!o) return fail(o.error());
      ms.push_back(frameMilliseconds(o->passTimes));
      row.triangles = o->trianglesDrawn;
    }
    std::sort(ms.begin(), ms.end());
    row.gpuMsMedian = ms[ms.size() / 2];
    row.gpuMsMax = ms.back();
    rows.push_back(row);
  }

  const runtime::SceneInfo& info = scene.info();
  auto worst = [&](auto field) {
    double w = 0;
    for (const CutRow& row : rows) w = std::max(w, double(field(row)));
    return w;
  };
  double worstGpu = worst([](const CutRow& x) { return x.gpuMsMax; });
  double worstCut = worst([](const CutRow& x) { return x.secondsToFullQuality; });
  double worstWall = worst([](const CutRow& x) { return x.wallMsMaxConverging; });
  double worstGpuConverging = worst([](const CutRow& x) { return x.gpuMsMaxConverging; });
  size_t unconverged = std::count_if(rows.begin(), rows.end(), [](const CutRow& x) { return !x.converged; });
  size_t overBudget = std::count_if(rows.begin(), rows.end(), [](const CutRow& x) { return x.pagesMissing > 0; });
  render::ResidencyTimes total;
  double totalMs = 0;
  for (const CutRow& x : rows) total += x.times, totalMs += x.secondsToFullQuality * 1e3;
  if (r.json) {
    nlohmann::json cams = nlohmann::json::array();
    for (const CutRow& x : rows)
      cams.push_back({{"camera", x.camera},
                      {"converged", x.converged},
                      {"frames_to_full_quality", x.framesToFullQuality},
                      {"seconds_to_full_quality", x.secondsToFullQuality},
                      {"wall_ms_max_frame_converging", x.wallMsMaxConverging},
                      {"gpu_ms_frame", x.gpuMsMedian},
                      {"gpu_ms_max_frame", x.gpuMsMax},
                      {"gpu_ms_max_frame_converging", x.gpuMsMaxConverging},
                      {"triangles", x.triangles},
                      {"bytes_read", x.bytesRead},
                      {"pages_loaded", x.pagesLoaded},
                      {"pages_evicted", x.pagesEvicted},
                      {"pages_missing", x.pagesMissing},
                      {"resident_bytes", x.residentBytes},
                      {"cpu_ms", residencyTimesJson(x.times, x.secondsToFullQuality * 1e3)}});
    nlohmann::json j = {{"bench", "render_lod_cuts"},
                        {"input", r.scene.input},
                        {"device", ctx.caps().name},
                        {"width", view.width},
                        {"height", view.height},
                        {"tau_pixels", view.config.tauPixels},
                        {"raster", render::toString(view.config.raster)},
                        {"gpu_budget", r.scene.gpuBudget},
                        {"prefetch", r.scene.prefetch},
                        {"source_triangles", info.sourceTriangles},
                        {"instances", info.instances},
                        {"clusters", info.clusters},
                        {"cluster_table_bytes", tableBytes},
                        {"load_seconds", info.loadSeconds},
                        {"timed_frames_per_camera", timedFrames},
                        {"cameras", cams},
                        {"unconverged_cameras", unconverged},
                        {"cameras_over_budget", overBudget},
                        {"worst_gpu_ms_frame", worstGpu},
                        {"worst_fps", worstGpu > 0 ? 1e3 / worstGpu : 0.0},
                        {"worst_seconds_to_full_quality", worstCut},
                        {"worst_wall_ms_frame_converging", worstWall},
                        {"worst_gpu_ms_frame_converging", worstGpuConverging},
                        {"cpu_ms", residencyTimesJson(total, totalMs)}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench render {} on {}: {} source triangles, {} instances, {} clusters ({:.1f} MB of cluster tables "
             "always resident) at {}x{}, tau {} px, raster {}, GPU budget {} bytes, {} camera cuts, {} timed frames "
             "each\n",
             r.scene.input, ctx.caps().name, info.sourceTriangles, info.instances, info.clusters,
             double(tableBytes) / 1e6, view.width, view.height, view.config.tauPixels,
             render::toString(view.config.raster), r.scene.gpuBudget, rows.size(), timedFrames);
  for (const CutRow& x : rows)
    fmt::print("camera {:3}: full quality after {:3} frames, {:7.3f} s ({:8.1f} MB read, {:4} pages loaded, {:4} "
               "evicted; slowest frame meanwhile {:7.2f} ms wall){}; then gpu {:7.3f} ms median, {:7.3f} max, {} "
               "triangles\n",
               x.camera, x.framesToFullQuality, x.secondsToFullQuality, double(x.bytesRead) / 1e6, x.pagesLoaded,
               x.pagesEvicted, x.wallMsMaxConverging,
               x.converged ? (x.pagesMissing ? fmt::format(" ({} pages over the budget)", x.pagesMissing) : "")
                           : " NOT converged",
               x.gpuMsMedian, x.gpuMsMax, x.triangles);
  if (r.stats)
    for (const CutRow& x : rows)
      fmt::print("camera {:3} until full quality: {}; {:.2f} ms elsewhere\n", x.camera, residencyTimesText(x.times),
                 x.secondsToFullQuality * 1e3 - x.times.renderThreadMs());
  fmt::print("worst: gpu frame {:.3f} ms ({:.0f} fps), full quality {:.3f} s after a cut, slowest frame while "
             "converging {:.2f} ms wall{}{}\n",
             worstGpu, worstGpu > 0 ? 1e3 / worstGpu : 0.0, worstCut, worstWall,
             unconverged ? fmt::format("; {} cameras NOT converged", unconverged) : "",
             overBudget ? fmt::format("; {} cameras with pages over the budget", overBudget) : "");
}

} // namespace mirage::cli
