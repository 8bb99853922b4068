#pragma once
// Shared pieces of the commands that render: output-path checks and timing summaries.
#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

#include <glm/glm.hpp>
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/io/import.h"
#include "mirage/render/camera.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::cli {

// The output's folder must exist and the extension must be one of `extensions` (".png", ...).
Status checkOutputPath(const std::filesystem::path& path, const std::vector<std::string>& extensions);
// "WxH" with 1 <= W, H <= 16384.
Status parseSize(const std::string& text, uint32_t& width, uint32_t& height);
// The Vulkan context every command runs on: `device` (name substring or index; empty: MIRAGE_DEVICE,
// then the best device).
Result<std::unique_ptr<gpu::Context>> openDevice(const std::string& device);
// A scene file, or "gen:KIND[:SIZE[:SEED]]" for a procedural scene made in memory (no file needed,
// which is how benchmarks run on machines without the data set).
Result<Scene> loadSceneArgument(const std::string& argument, const io::ImportOptions& options = {});
// The scene restricted to the PVS of the view cell holding `eye` (`pvs` loaded from `pvsPath`, a
// .mrg from `mirage pvs`, which errors name). Errors: a PVS of another scene, an eye in none of its
// cells. `cell` receives the cell index.
Result<Scene> restrictSceneToPvs(const Scene& scene, const vis::PvsData& pvs, const std::string& pvsPath, glm::vec3 eye,
                                 int& cell);
// Benchmarks render untimed frames for this long before timing: an idle GPU can stay at its low
// clock through short frames (on the H200 whole processes then ran up to 5x slower, every pass
// alike). `--warmup-ms` on the bench commands.
inline constexpr double kBenchWarmupMs = 1000.0;
// Median over frames of each pass's GPU time (frames[i] lists the passes of frame i).
std::vector<gpu::PassTime> medianPassTimes(const std::vector<std::vector<gpu::PassTime>>& frames);
// The whole frame's GPU time among a frame's pass times ("frame"), 0 when absent.
double frameMilliseconds(const std::vector<gpu::PassTime>& times);

// The four views the PVS benches time from a view cell: at its centre, level, 90 degrees apart,
// 70 degree field of view (clip planes left for the caller to derive).
std::array<render::Camera, 4> cellViewCameras(const vis::ViewCell& cell);

} // namespace mirage::cli
