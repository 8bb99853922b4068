#pragma once
// The viewer's frame figures (docs/viewer.md "Latency"): the loop's wall time per frame and, per
// presented frame, input-to-present latency split at the submit, all in one steady clock. The
// overlay shows recent means, the run ends with one summary line.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mirage::viewer {

struct FrameLog {
  std::vector<double> frameMs;          // wall time of each loop iteration (1000 / FPS)
  std::vector<double> inputToSubmitMs;  // input poll -> the frame's queue submit
  std::vector<double> inputToPresentMs; // input poll -> vkQueuePresentKHR returned
  std::vector<double> submitToGpuMs;    // submit -> the frame's fence seen signalled (upper bound)
  std::vector<double> gpuFrameMs;       // the renderer's "frame" pass (timestamp queries)
  std::vector<double> tau;              // --target-ms: the tau each frame was drawn with
};

// A frame slot's submit waiting for its fence: the GPU-done time is taken the first time the loop
// sees the fence signalled (each iteration and when the slot comes round again), so it is late by
// at most one loop iteration.
struct SubmitStamp {
  bool pending = false;
  double submitSeconds = 0.0;
};

struct Figure {
  double mean = 0.0, p95 = 0.0; // p95: nearest rank
  size_t count = 0;
};
Figure figure(std::span<const double> values);
// Mean of the last `last` values (the overlay's figures), 0 when empty.
double recentMean(std::span<const double> values, size_t last = 60);
// "viewed N frames in S s: F FPS, frame mean/p95, latency mean/p95 (and its parts), GPU median"
// (and the chosen tau's mean and range with frame-time control).
std::string summaryLine(const FrameLog& log, uint64_t frames, double seconds, const std::string& device);

} // namespace mirage::viewer
