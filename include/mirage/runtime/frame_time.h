#pragma once
// Frame-time control (docs/runtime.md): holds a target GPU frame time by choosing the next frame's
// LOD threshold tau and surfel size from the last frames' measured GPU times. One control variable,
// the detail scale s >= 1: tau = tauMin * s, surfel size = surfelMin * s (each clamped to its bounds).
// The work of both renderers goes as 1/s^2 (triangles of a cut at error tau ~ 1/tau^2; surfels of
// a prefix at size d ~ 1/d^2, Brandt et al. 2019), so a frame of t ms drawn at scale s estimates
// the scale that meets the target T as s * sqrt(t / T). The controller smooths those estimates in
// log space: they are absolute (not steps), so a measurement that arrives frames late (frames in
// flight) is still paired with the scale it was drawn at and cannot wind up an oscillation.
#include <cstdint>

#include "mirage/core/result.h"
#include "mirage/runtime/config.h"

namespace mirage::runtime {

struct FrameTimeSettings {
  double targetMs = 0.0;                        // the GPU frame time to hold (--target-ms)
  float tauMin = 1.0f;                          // pixels: the finest detail, used whenever the target allows it
  float tauMax = 16.0f;                         // pixels: the coarsest detail the controller may choose
  float surfelMin = kSurfelDefaults.surfelSize; // pixels, at tauMin (validate(): 0.5..16)
  float surfelMax = 16.0f;
  // Weight of the newest estimate in the log-space average (1: follow each frame; lower: steadier
  // under noisy timings, slower to recover).
  double smoothing = 0.5;
  // Hysteresis: a frame within this fraction of the target changes nothing (well inside the
  // +-10 % the controller is judged by, so it settles instead of chasing timer noise).
  double band = 0.05;
  // The most the scale moves in one frame, as a factor: a single spike cannot throw the detail away.
  double maxStep = 2.0;
};

// Range checks: the messages name the flag (--target-ms).
Status validate(const FrameTimeSettings& settings);

struct FrameTimeState {
  double logScale = 0.0; // smoothed log(s); s = 1 is tauMin
  uint64_t updates = 0;  // frames fed
  uint64_t held = 0;     // frames inside the hysteresis band (no change)
};

// The state that renders `config`'s tau (clamped to the bounds) first.
FrameTimeState startFrameTime(const FrameTimeSettings& settings, const RenderConfig& config);

// Feeds one measured frame: `gpuMs` of a frame drawn with `tauUsed` (the tau that frame had; with
// frames in flight, an older one than the current). Non-finite or non-positive times are ignored.
void updateFrameTime(const FrameTimeSettings& settings, FrameTimeState& state, float tauUsed, double gpuMs);

// The tau and surfel size the state chooses, written into `config` (other fields untouched).
void applyFrameTime(const FrameTimeSettings& settings, const FrameTimeState& state, RenderConfig& config);
float frameTimeTau(const FrameTimeSettings& settings, const FrameTimeState& state);
float frameTimeSurfelSize(const FrameTimeSettings& settings, const FrameTimeState& state);

} // namespace mirage::runtime
