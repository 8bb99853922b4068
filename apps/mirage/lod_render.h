#pragma once
// `mirage render scene.mrg` and `mirage bench render scene.mrg`: the cluster-LOD path of
// runtime::Scene (cmd_render_lod.cpp prints what it renders).
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "mirage/runtime/scene.h"
#include "render_options.h"

namespace mirage::cli {

struct LodRenderRequest {
  // .mrg; --pvs pvs.mrg (a triangle PVS of the scene the asset was built from): cull with the cluster
  // PVS of the camera's view cell. Bench: every frame timed with and without it; with no --camera or
  // --path, cameras at every cell's centre looking four ways. --surfels on a .mrg with DAGs and
  // per-mesh SURF chunks: meshes near, surfels far.
  runtime::SceneOptions scene;
  std::string output; // .png (render only)
  std::string exr;    // optional linear image (render only)
  std::string camera; // empty: auto 3/4 view
  std::string path;   // camera path: cameras.json or orbit:N (render: one image per camera)
  std::string size = "1920x1080";
  std::string device;
  runtime::RenderConfig config;
  BenchSweeps sweeps;    // bench: the choices timed in one run
  int frames = 1;        // render: --repeat; bench: --frames (the first is a warm-up)
  double warmupMs = 0.0; // bench: the warm-up frame repeats for this long (GPU clock)
  bool stats = false;
  bool json = false;
  std::string progressJson; // render: per-frame progress until convergence (lod_progress.h)
  bool baselines = false;   // bench: also brute force and a discrete LOD chain (forward renderer)
  // --stereo --ipd: both eyes side by side; bench: also one eye mono in the same run (the ratio).
  std::optional<float> stereoIpd;
  // bench --target-ms: each frame's tau from the frame-time controller fed with the previous
  // frames' GPU times; one configuration, each frame reported.
  std::optional<runtime::FrameTimeSettings> frameTime;
  // render --particles: an effect file stepped particleFrames times (1/60 s) and drawn with the scene.
  std::string particles;
  uint32_t particleFrames = 60;
  std::string particleSim = "cpu";
  bool particleSplat = true; // false: every particle a billboard
};

void runLodRender(const LodRenderRequest& request);
// Residency frames' CPU time by phase (render::ResidencyTimes), milliseconds; with the frames' wall
// time, `other_ms` is what no phase holds.
nlohmann::json residencyTimesJson(const render::ResidencyTimes& t, std::optional<double> wallMs = std::nullopt);
std::string residencyTimesText(const render::ResidencyTimes& t);
// bench render with --gpu-budget and --path (lod_cuts.cpp): every camera a cut; per camera the time
// to the first full-quality frame and the GPU frame time at the converged residency. `view` holds
// size and configuration; `path` the cameras.
void runCutBench(gpu::Context& ctx, runtime::Scene& scene, runtime::View view, const std::vector<render::Camera>& path,
                 const LodRenderRequest& request);
void runLodBench(const LodRenderRequest& request);

} // namespace mirage::cli
