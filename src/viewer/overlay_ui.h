#pragma once
// The overlay's panel: frame figures (FPS, frame time, per-pass GPU times, what was drawn, view
// cell) and the controls that map to renderer settings. Plain ImGui calls between NewFrame and
// Render; the state it edits lives in the viewer loop.
#include <string>
#include <vector>

#include "scene_view.h"

namespace mirage::viewer {

struct UiState {
  ViewConfig config;
  bool vsync = true;
  bool recording = false;
  size_t recorded = 0; // cameras recorded so far
  bool replaying = false;
  double cpuFrameMs = 0.0; // smoothed wall time per frame
  // Latency of the last presented frames (frame_log.h), means in milliseconds.
  double inputToSubmitMs = 0.0, submitToGpuMs = 0.0, inputToPresentMs = 0.0;
  // --target-ms: the controller chooses tau (and the surfel size) each frame while `holdTarget`.
  double targetMs = 0.0; // 0: no frame-time control
  bool holdTarget = false;
  float stereoIpd = 0.0f; // > 0: both eyes side by side
  std::string camera;     // the last camera printed with C (a --camera string)
  std::string message;    // last action or error (screenshot written, ...)
  bool clusterLod = false, hasSurfels = false, hasPvs = false;
  bool hasBlend = false; // cluster LOD with alpha BLEND materials: the transparency switch
  bool mixed = false;    // cluster LOD with surfels far away: the surfels switch
};

// Draws the panel; returns true when a setting changed.
bool drawOverlayPanel(UiState& state, const FrameStats& stats);

} // namespace mirage::viewer
