#pragma once
// `mirage render --gpu-budget SIZE --progress-json FILE`: the progressive start of a streamed
// paged .mrg, frame by frame until the residency converged (docs/render.md, "Residency").
#include <chrono>
#include <string>

#include "mirage/core/result.h"
#include "mirage/runtime/scene.h"

namespace mirage::cli {

// Per frame (runtime::View::readEveryFrame): seconds since `opened` (just before the scene was
// opened, so the index and root pages count), bytes received and read, pages, and the frame's PSNR
// against the converged (last) image; then when the frames first reached 30 and 40 dB. Written
// whole or not at all.
Status writeProgressJson(const std::string& path, const std::string& input, uint64_t bandwidthBitsPerSecond,
                         const runtime::Frame::Residency& residency, std::chrono::steady_clock::time_point opened);

} // namespace mirage::cli
