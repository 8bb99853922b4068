#pragma once
// `mirage client`: the native thin client over the network (docs/stream.md, "Client"). Connects,
// then along a camera path: sends each pose, applies the frames that come back and renders the
// path's camera from what it holds.
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/stream/net_sim.h"
#include "mirage/stream/protocol.h"
#include "mirage/stream/transport.h"

namespace mirage::stream {

class StreamView;

struct StreamClientOptions {
  std::string url;    // ws://host:port/ or wss://host:port/
  std::string token;  // the server's shared secret
  std::string caFile; // wss: certificates to trust (empty: the system's)
  uint32_t width = 1280, height = 720;
  // The atlas codecs offered (the zstd patch section is always: transportConfig adds it).
  uint32_t capabilities = kCapabilityZstdTiles | kCapabilityH264;
  std::chrono::milliseconds timeout{10000}; // connecting, and waiting for each frame
  uint32_t maxFrameBytes = 256u << 20;      // largest server message accepted
  // Both eyes side by side (clientEyes of each camera): the images are
  // 2 * width x height, width x height per eye (docs/stream.md, "The native client window and stereo").
  std::optional<float> stereoIpd;
};

// Per path camera: what arrived and what was drawn.
struct ClientFrameInfo {
  size_t index = 0;         // camera of the path
  size_t count = 0;         // cameras in the path
  uint32_t serverFrame = 0; // Frame.sequence applied last
  uint64_t frameBytes = 0;  // bytes of the frames applied for this camera
  uint64_t atlasBytes = 0;
  size_t patchesHeld = 0;
  size_t particlesHeld = 0; // the particles of the frame applied last
  double roundTripMs = 0;   // pose sent -> its frame applied (the latest frame applied for this camera)
  AtlasCodec codec = AtlasCodec::None;
  uint32_t framesApplied = 0;  // frames applied for this camera (open loop: 0 while none arrived)
  uint32_t framesInFlight = 0; // open loop: poses delivered or on their way whose frames have not arrived
  bool poseLost = false;       // open loop: this camera's pose was lost on the way up
};

using ClientFrameSink = std::function<Status(const ClientFrameInfo&, const render::RenderOutput&)>;

// The protocol's options of a client: token, codecs (with kCapabilityZstdPatches), viewport (one
// eye's), stereo, limits.
ClientConfig transportConfig(const StreamClientOptions& options);

// A frame as it arrived, with the size of its message.
struct ReceivedFrame {
  Frame frame;
  uint64_t bytes = 0;
};

// Sends `pose` and receives the server's frames up to the one answering it, in order (frames
// answering earlier poses may come first). Errors: the connection lost or closed by the server (its
// reason), a message other than a Frame, nothing within options.timeout.
Result<std::vector<ReceivedFrame>> exchangePose(TransportClient& transport, const Pose& pose,
                                                const StreamClientOptions& options);

// Applies `received` to `view` and counts it in `info` (frames applied, bytes, last server frame). A
// frame that does not apply closes the connection (Close Malformed) and is an error naming the URL.
Status applyReceivedFrame(StreamView& view, TransportClient& transport, const ReceivedFrame& received,
                          const StreamClientOptions& options, ClientFrameInfo& info);

// The eyes a stereo client draws for `camera`: render::stereoEyes, each with its own clip planes (as
// the forward renderer's `mirage render --stereo`).
std::array<render::Camera, 2> clientEyes(const render::Camera& camera, float ipd);

// The Pose of a client frame. Mono: camera = `current`, predicted = `predicted`. Stereo: the server's
// visibility and level selection take the union of Pose.camera and Pose.predicted, so a stereo pose
// carries the two eyes of the predicted camera, left as camera and right as predicted: both eyes are
// covered exactly where the answer is expected to be shown (the current view, already past when the
// answer arrives, is not sent).
Pose clientPose(uint32_t sequence, const render::Camera& current, const render::Camera& predicted, uint32_t width,
                uint32_t height, std::optional<float> stereoIpd);

// Pose prediction: `current` moved on linearly, eye and target alike, by its motion from `previous`
// (`stepSeconds` earlier) over `aheadSeconds` (the measured round trip). Fov, up and clip planes are
// the current camera's; no motion (or stepSeconds <= 0) predicts the current camera.
render::Camera extrapolateCamera(const render::Camera& previous, const render::Camera& current, double stepSeconds,
                                 double aheadSeconds);

// `left` and `right` (same height) side by side: (left.width + right.width) x height.
ImageRGBA8 sideBySide(const ImageRGBA8& left, const ImageRGBA8& right);

// Lock-step along `path` (a camera JSON file, or orbit:N around the bounds the server's Welcome
// gives): for each camera, sends its pose (current = predicted = the camera; clientPose with stereo),
// waits for the frame answering it, applies it and renders that camera (both eyes side by side with
// stereo: RenderOutput.srgb only), then calls `sink`. Errors: connection refused
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
