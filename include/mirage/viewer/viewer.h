#pragma once
// `mirage view SCENE`: an interactive window on a scene (fly camera, Dear ImGui overlay with frame
// times and renderer switches, camera path record / replay, screenshots), and a headless mode for
// tests that renders a camera path to PNGs exactly as `mirage render --path` does. docs/viewer.md.
#include <cstdint>
#include <string>

#include "mirage/core/result.h"

namespace mirage::viewer {

struct ViewerOptions {
  std::string scene;             // .mrg or a scene file
  std::string camera;            // --camera string; empty: the automatic 3/4 view
  std::string size = "1280x720"; // window (and render) size WxH
  std::string present = "fifo";  // fifo | mailbox | immediate (falls back to fifo)
  std::string device;            // Vulkan device name substring or index
  std::string pvs;               // .mrg: triangle PVS, culls with the camera's view cell
  bool surfels = false;          // .mrg: per-mesh surfels far away
  std::string path;              // camera path (cameras.json or orbit:N): replayed, one camera per frame
  std::string screenshot;        // with --path: OUT.png -> OUT_0000.png ... (the image without overlay)
  bool exitAfterPath = false;    // close after the path (needs --path and --screenshot)
  uint32_t maxFrames = 0;        // >0: close after this many frames (smoke tests, measurements)
};

// Runs the viewer until its window closes. Errors (one line, naming the file): bad options, a scene
// that fails to load (before any window opens), no display, no device that can present.
Status runViewer(const ViewerOptions& options);

} // namespace mirage::viewer
