#pragma once
// `mirage view SCENE`: an interactive window on a scene (fly camera, Dear ImGui overlay with frame
// times and renderer switches, camera path record / replay, screenshots), and a headless mode for
// tests that renders a camera path to PNGs exactly as `mirage render --path` does. docs/viewer.md.
#include <cstdint>
#include <optional>
#include <string>

#include "mirage/core/result.h"
#include "mirage/runtime/config.h"
#include "mirage/runtime/frame_time.h"

namespace mirage::viewer {

struct ViewerOptions {
  std::string scene;              // .mrg or a scene file
  std::string camera;             // --camera string; empty: the automatic 3/4 view
  std::string size = "1280x720";  // window (and render) size WxH
  std::string present = "fifo";   // fifo | mailbox | immediate (falls back to fifo)
  std::string device;             // Vulkan device name substring or index
  std::string pvs;                // .mrg: triangle PVS, culls with the camera's view cell
  bool surfels = false;           // .mrg: per-mesh surfels far away
  std::string materials;          // material file (TOML) applied to the scene (docs/shading.md)
  uint64_t gpuBudget = 0;         // paged .mrg: GPU residency budget in bytes (runtime::SceneOptions::gpuBudget)
  uint64_t bandwidth = 0;         // .mrg file or URL: receive limit in bits per second (0: none)
  std::string path;               // camera path (cameras.json or orbit:N): replayed, one camera per frame
  std::string screenshot;         // with --path: OUT.png -> OUT_0000.png ... (the image without overlay)
  bool exitAfterPath = false;     // close after the path (needs --path)
  uint32_t maxFrames = 0;         // >0: close after this many frames (smoke tests, measurements)
  std::string keys;               // action keys pressed at given frames: "F12@2,C@3" (scripted runs)
  runtime::RenderConfig config;   // the renderer's settings at start (the overlay edits them)
  bool clusterLodFlags = false;   // a cluster-LOD-only setting was given (refused on other scenes)
  bool surfelFlags = false;       // a surfel setting was given (needs --surfels)
  std::optional<float> stereoIpd; // cluster LOD: both eyes side by side, the window 2x --size wide
  std::optional<runtime::FrameTimeSettings> frameTime; // cluster LOD: tau from the last frames' GPU times
};

// Runs the viewer until its window closes, then prints one summary line (frames, FPS, frame time
// and input-to-present latency). Errors (one line, naming the file): bad options, a scene that fails
// to load or whose first frame fails with the settings given (before any window opens), no display,
// no device that can present.
Status runViewer(const ViewerOptions& options);

} // namespace mirage::viewer
