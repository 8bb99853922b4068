// Frame-time control: log-space averaging of the scale each frame's time asks for (frame_time.h).
#include "mirage/runtime/frame_time.h"

#include <algorithm>
#include <cmath>

namespace mirage::runtime {

namespace {

double maxLogScale(const FrameTimeSettings& s) { return std::log(double(s.tauMax) / double(s.tauMin)); }

} // namespace

Status validate(const FrameTimeSettings& s) {
  if (!(s.targetMs > 0.0) || s.targetMs > 1e5) return Error{"--target-ms must be a positive number of milliseconds"};
  if (!(s.tauMin > 0.0f) || !(s.tauMax >= s.tauMin) || s.tauMax > 1e6f)
    return Error{"--target-ms: tau bounds must satisfy 0 < min <= max"};
  if (!(s.surfelMin >= 0.5f) || !(s.surfelMax >= s.surfelMin) || s.surfelMax > 16.0f)
    return Error{"--target-ms: surfel size bounds must satisfy 0.5 <= min <= max <= 16"};
  if (!(s.smoothing > 0.0 && s.smoothing <= 1.0) || !(s.band >= 0.0 && s.band < 1.0) || !(s.maxStep > 1.0))
    return Error{"--target-ms: smoothing in (0, 1], band in [0, 1), max step above 1"};
  return Ok{};
}

FrameTimeState startFrameTime(const FrameTimeSettings& s, const RenderConfig& config) {
  FrameTimeState state;
  double tau = std::clamp(double(config.tauPixels), double(s.tauMin), double(s.tauMax));
  state.logScale = std::log(tau / double(s.tauMin));
  return state;
}

void updateFrameTime(const FrameTimeSettings& s, FrameTimeState& state, float tauUsed, double gpuMs) {
  if (!std::isfinite(gpuMs) || !(gpuMs > 0.0) || !(tauUsed > 0.0f)) return;
  ++state.updates;
  double error = std::log(gpuMs / s.targetMs);
  double usedLog = std::clamp(std::log(double(tauUsed) / double(s.tauMin)), 0.0, maxLogScale(s));
  // Inside the band nothing moves: a met target is kept, whatever the noise.
  if (std::abs(error) <= std::log1p(s.band)) {
    ++state.held;
    return;
  }
  // Work ~ 1/s^2: the scale that meets the target is s * sqrt(t / T), here in logs.
  double wanted = usedLog + 0.5 * error;
  double next = state.logScale + s.smoothing * (wanted - state.logScale);
  double step = std::log(s.maxStep);
  next = std::clamp(next, state.logScale - step, state.logScale + step);
  state.logScale = std::clamp(next, 0.0, maxLogScale(s));
}

float frameTimeTau(const FrameTimeSettings& s, const FrameTimeState& state) {
  return std::clamp(float(double(s.tauMin) * std::exp(state.logScale)), s.tauMin, s.tauMax);
}

float frameTimeSurfelSize(const FrameTimeSettings& s, const FrameTimeState& state) {
  return std::clamp(float(double(s.surfelMin) * std::exp(state.logScale)), s.surfelMin, s.surfelMax);
}

void applyFrameTime(const FrameTimeSettings& s, const FrameTimeState& state, RenderConfig& config) {
  config.tauPixels = frameTimeTau(s, state);
  config.surfelSize = frameTimeSurfelSize(s, state);
}

} // namespace mirage::runtime
