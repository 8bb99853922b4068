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
#include "mirage/runtime/scene_argument.h"

namespace mirage::cli {

// The output's folder must exist and the extension must be one of `extensions` (".png", ...).
Status checkOutputPath(const std::filesystem::path& path, const std::vector<std::string>& extensions);
// "WxH" with 1 <= W, H <= 16384.
Status parseSize(const std::string& text, uint32_t& width, uint32_t& height);
// The Vulkan context every command runs on: `device` (name substring or index; empty: MIRAGE_DEVICE,
// then the best device).
Result<std::unique_ptr<gpu::Context>> openDevice(const std::string& device);
// Scene arguments, PVS restriction and cell views live in the runtime (mirage/runtime/scene_argument.h).
using runtime::cellViewCameras;
using runtime::loadSceneArgument;
using runtime::restrictSceneToPvs;
// Benchmarks render untimed frames for this long before timing: an idle GPU can stay at its low
// clock through short frames (on the H200 whole processes then ran up to 5x slower, every pass
// alike). `--warmup-ms` on the bench commands.
inline constexpr double kBenchWarmupMs = 1000.0;
// Median over frames of each pass's GPU time (frames[i] lists the passes of frame i).
std::vector<gpu::PassTime> medianPassTimes(const std::vector<std::vector<gpu::PassTime>>& frames);
// The whole frame's GPU time among a frame's pass times ("frame"), 0 when absent.
double frameMilliseconds(const std::vector<gpu::PassTime>& times);

} // namespace mirage::cli
