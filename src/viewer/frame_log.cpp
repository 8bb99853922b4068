#include "frame_log.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

namespace mirage::viewer {

Figure figure(std::span<const double> values) {
  Figure f;
  f.count = values.size();
  if (values.empty()) return f;
  std::vector<double> sorted(values.begin(), values.end());
  std::sort(sorted.begin(), sorted.end());
  f.mean = std::accumulate(sorted.begin(), sorted.end(), 0.0) / double(sorted.size());
  size_t rank = size_t(std::ceil(0.95 * double(sorted.size())));
  f.p95 = sorted[std::max<size_t>(rank, 1) - 1];
  return f;
}

double recentMean(std::span<const double> values, size_t last) {
  if (values.empty() || last == 0) return 0.0;
  auto recent = values.last(std::min(last, values.size()));
  return std::accumulate(recent.begin(), recent.end(), 0.0) / double(recent.size());
}

std::string summaryLine(const FrameLog& log, uint64_t frames, double seconds, const std::string& device) {
  Figure frame = figure(log.frameMs), present = figure(log.inputToPresentMs);
  Figure submit = figure(log.inputToSubmitMs), gpuDone = figure(log.submitToGpuMs);
  std::vector<double> gpu = log.gpuFrameMs;
  std::sort(gpu.begin(), gpu.end());
  std::string tau;
  if (!log.tau.empty()) {
    auto [lo, hi] = std::minmax_element(log.tau.begin(), log.tau.end());
    tau = fmt::format(", tau mean {:.2f} px ({:.2f}..{:.2f})", figure(log.tau).mean, *lo, *hi);
  }
  return fmt::format("viewed {} frames in {:.2f} s: {:.1f} FPS, frame mean {:.1f} ms p95 {:.1f} ms, input->present "
                     "mean {:.1f} ms p95 {:.1f} ms (input->submit {:.1f} ms, submit->GPU done {:.1f} ms), GPU frame "
                     "median {:.3f} ms{} ({})",
                     frames, seconds, seconds > 0.0 ? double(frames) / seconds : 0.0, frame.mean, frame.p95,
                     present.mean, present.p95, submit.mean, gpuDone.mean, gpu.empty() ? 0.0 : gpu[gpu.size() / 2], tau,
                     device);
}

} // namespace mirage::viewer
