#pragma once
// `mirage client`: the native thin client over the network (docs/stream.md, "Client"). Connects,
// then along a camera path: sends each pose, applies the frames that come back and renders the
// path's camera from what it holds.
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/stream/net_sim.h"
#include "mirage/stream/protocol.h"

namespace mirage::stream {

struct StreamClientOptions {
  std::string url;    // ws://host:port/ or wss://host:port/
  std::string token;  // the server's shared secret
  std::string caFile; // wss: certificates to trust (empty: the system's)
  uint32_t width = 1280, height = 720;
  uint32_t capabilities = kCapabilityZstdTiles | kCapabilityH264; // the atlas codecs offered
  std::chrono::milliseconds timeout{10000};                       // connecting, and waiting for each frame
  uint32_t maxFrameBytes = 256u << 20;                            // largest server message accepted
};

// Per path camera: what arrived and what was drawn.
struct ClientFrameInfo {
  size_t index = 0;         // camera of the path
  size_t count = 0;         // cameras in the path
  uint32_t serverFrame = 0; // Frame.sequence applied last
  uint64_t frameBytes = 0;  // bytes of the frames applied for this camera
  uint64_t atlasBytes = 0;
  size_t patchesHeld = 0;
  double roundTripMs = 0; // pose sent -> its frame applied (the latest frame applied for this camera)
  AtlasCodec codec = AtlasCodec::None;
  uint32_t framesApplied = 0;  // frames applied for this camera (open loop: 0 while none arrived)
  uint32_t framesInFlight = 0; // open loop: poses delivered or on their way whose frames have not arrived
  bool poseLost = false;       // open loop: this camera's pose was lost on the way up
};

using ClientFrameSink = std::function<Status(const ClientFrameInfo&, const render::RenderOutput&)>;

// Lock-step along `path` (a camera JSON file, or orbit:N around the bounds the server's Welcome
// gives): for each camera, sends its pose (current = predicted = the camera), waits for the frame
// answering it, applies it and renders that camera, then calls `sink`. Errors: connection refused
// (with the server's reason), a frame that does not decode or apply, no answer within the timeout.
Status runPathClient(gpu::Context& context, const StreamClientOptions& options, const std::string& path,
                     const ClientFrameSink& sink);

// The open-loop client under a simulated network (net_sim.h; docs/stream.md, "Simulated network").
struct SimulatedClientOptions {
  NetSimConfig network;
  uint32_t fps = 60;   // the client's frame rate: camera i is drawn at virtual time i / fps
  double serverMs = 0; // virtual time the server takes to answer a pose (the network's delays come on top)
};

// Open loop along `path` on a virtual clock: at each camera i (time i / fps) the client sends the
// pose of camera i with camera i + (mean round trip in frames) as the predicted view (clamped to the
// path), applies every frame that has arrived by then and draws camera i from what it holds (the
// background until the first frame arrives), then calls `sink`. Poses wait in the simulated uplink
// and frames in the downlink (NetSim); the real exchange with the server happens when a pose
// arrives there, one pose at a time, so the result depends only on the path, the options and the
// seed, never on the machine's speed. Frames still in flight after the last camera are dropped.
// Errors: as runPathClient's, and a network configuration out of range.
Status runSimulatedPathClient(gpu::Context& context, const StreamClientOptions& options, const std::string& path,
                              const SimulatedClientOptions& simulation, const ClientFrameSink& sink);

} // namespace mirage::stream
