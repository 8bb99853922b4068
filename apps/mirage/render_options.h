#pragma once
// The one CLI binding of runtime::RenderConfig, used by render, bench render (and view): typed
// options (enums through the renderers' name parsers), defaults from the config struct, ranges
// checked by runtime::validate.
#include <optional>
#include <string>
#include <vector>

#include "mirage/runtime/config.h"
#include "mirage/runtime/frame_time.h"
#include "mirage/runtime/scene.h"

namespace CLI {
class App;
class Option;
} // namespace CLI

namespace mirage::cli {

enum class BindMode { Render, Bench };

// Bench-only sweep values. In BindMode::Bench, --raster all, --blend-raster all, --selection all
// and --occlusion both set these flags instead of a config value (which keeps its default); the
// bench then times each choice in one run. Render mode refuses those words like any other.
struct BenchSweeps {
  bool allRasters = true; // --raster all: the bench default, every backend the device has
  bool allBlendRasters = false;
  bool allSelections = false;
  bool bothOcclusion = false;
  bool bothLean = false; // --lean-raster both
};

// The options bound, so that commands can tell what was given (CLI11 counts, no sentinels).
struct RenderConfigOptions {
  std::vector<CLI::Option*> clusterLod; // --tau --raster --hybrid-threshold --lean-raster --blend-queue-pixels
                                        // --occlusion --cones --selection --blend-raster --debug-view --fovea*
  std::vector<CLI::Option*> surfels;    // --surfel-size (--surfel-raster in render)
};
bool anyGiven(const std::vector<CLI::Option*>& options);

// The one CLI binding of runtime::SceneOptions but its input (a positional whose help differs per
// command): --materials, --pvs and --surfels; render: --surfel-order; bench: --grid. Returns --surfel-order
// (null in bench mode).
CLI::Option* bindSceneOptions(CLI::App& command, runtime::SceneOptions& options, BindMode mode);
// --materials FILE.toml alone (SceneOptions::materials): bindSceneOptions binds it, and view, whose
// other scene options differ.
void bindMaterials(CLI::App& command, std::string& materials);
// --gpu-budget SIZE (64MB, 1GB; SceneOptions::gpuBudget): bindSceneOptions binds it, and view.
void bindGpuBudget(CLI::App& command, uint64_t& budget);
// --bandwidth RATE (20Mbit; asset::parseBandwidth): the .mrg's reads, file or URL, within RATE bits
// per second (SceneOptions::source); bindSceneOptions binds it, and view.
void bindBandwidth(CLI::App& command, uint64_t& bitsPerSecond);

// --stereo [--ipd D] (render, bench render; cluster LOD scenes): runtime::View::stereoIpd.
struct StereoOptions {
  bool enabled = false;
  float ipd = render::kDefaultIpd;
  std::optional<float> ipdOrNone() const { return enabled ? std::optional<float>(ipd) : std::nullopt; }
};
void bindStereo(CLI::App& command, StereoOptions& stereo);

RenderConfigOptions bindRenderConfig(CLI::App& command, runtime::RenderConfig& config, BindMode mode,
                                     BenchSweeps* sweeps = nullptr);

// --target-ms: frame-time control (runtime/frame_time.h) holds this GPU frame time by choosing
// each frame's tau and surfel size (ask the option whether it was given). Used by bench render.
CLI::Option* bindFrameTimeTarget(CLI::App& command, runtime::FrameTimeSettings& settings);

} // namespace mirage::cli
