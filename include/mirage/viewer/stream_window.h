#pragma once
// `mirage client URL` without --record: the stream client in a window (docs/stream.md, "The native
// client window and stereo"). The viewer's window, swapchain, fly camera and overlay; each display
// frame polls the connection without waiting, applies the frames that arrived, sends the current
// pose (with a predicted one) while few poses are unanswered, and draws the latest state, so the
// display runs at its own rate whatever the server's (frame-rate upsampling).
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/stream/client.h"

namespace mirage::viewer {

struct PolledInput;

struct StreamWindowOptions {
  stream::StreamClientOptions client; // url, token, codecs, size per eye, stereoIpd, timeout
  std::string present = "fifo";       // fifo | mailbox | immediate
  std::string device;                 // Vulkan device name substring or index
  uint32_t maxPosesInFlight = 2;      // poses sent and not yet answered, at most (1: lock-step)
  uint32_t maxFrames = 0;             // > 0: close after this many display frames
  // With maxFrames: also wait for this many server frames applied (a slow server, e.g. under
  // sanitizers, cannot end a smoke run before its first frame; the frame timeout still applies).
  uint32_t minServerFrames = 0;
  // Tests: edits the window's input of display frame `frame` (server frames applied so far) before
  // the loop reads it; returning false makes this frame the last.
  std::function<bool(uint64_t frame, uint64_t serverFrames, PolledInput& input)> script;
  bool captureLast = false; // keep the last frame's image (without overlay) in the summary
  bool validation = false;  // Vulkan validation layers (also on with MIRAGE_VALIDATION=1)
};

struct StreamWindowSummary {
  uint64_t displayFrames = 0; // frames drawn and presented
  uint64_t posesSent = 0;
  uint64_t serverFrames = 0; // frames received and applied
  size_t patchesHeld = 0;    // at the end
  double meanRoundTripMs = 0.0;
  uint32_t validationIssues = 0; // of the window's Vulkan context
  render::Camera camera;         // of the last frame (the centre camera with stereo)
  ImageRGBA8 last;               // captureLast: the last frame drawn (2W x H with stereo)
};

// Connects (errors before any window opens: refused, unreachable, bad options), opens the window
// and runs until it closes or the server closes the connection (an error carrying its reason),
// then prints one summary line. A frame that does not apply closes the connection with an error.
Result<StreamWindowSummary> runStreamWindow(const StreamWindowOptions& options);

} // namespace mirage::viewer
