// The open-loop client under a simulated network (client.h, net_sim.h; docs/stream.md,
// "Simulated network").
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "mirage/stream/client.h"
#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"
#include "mirage/stream/transport.h"

namespace mirage::stream {

namespace {

// The virtual time camera `index` is drawn at, in microseconds.
uint64_t cameraTimeUs(size_t index, uint32_t fps) { return uint64_t(index) * 1000000u / fps; }

struct PoseOnItsWay {
  uint64_t arrivalUs = 0; // at the server
  Pose pose;
};

// Frames the mean round trip (plus the server's time) spans at `fps`: how far ahead the predicted
// view looks.
size_t framesAhead(const SimulatedClientOptions& simulation) {
  double ms = meanRoundTripMs(simulation.network) + simulation.serverMs;
  return size_t(std::lround(ms * simulation.fps / 1000.0));
}

Status checkSimulation(const SimulatedClientOptions& simulation) {
  if (auto s = checkNetSimConfig(simulation.network); !s) return s;
  if (simulation.fps == 0 || simulation.fps > 1000)
    return Error{fmt::format("network simulation: client frame rate {} not in 1..1000", simulation.fps)};
  if (!std::isfinite(simulation.serverMs) || simulation.serverMs < 0.0 || simulation.serverMs > 60000.0)
    return Error{fmt::format("network simulation: server time {} ms not in [0, 60000]", simulation.serverMs)};
  return Ok{};
}

} // namespace

Status runSimulatedPathClient(gpu::Context& context, const StreamClientOptions& options,
                              const std::string& pathArgument, const SimulatedClientOptions& simulation,
                              const ClientFrameSink& sink) {
  if (auto s = checkSimulation(simulation); !s) return s;
  TransportClient transport;
  ClientConfig config = transportConfig(options);
  config.hello.stereo = false; // the open loop draws one eye
  auto welcome = transport.connect(options.url, config);
  if (!welcome) return welcome.error();
  auto view = StreamView::create(context, *welcome);
  if (!view) return view.error();
  Bounds bounds;
  bounds.add(welcome->sceneMin);
  bounds.add(welcome->sceneMax);
  auto cameras = render::cameraPathArgument(pathArgument, bounds, float(options.width) / float(options.height));
  if (!cameras) return cameras.error();
  const std::vector<render::Camera>& path = *cameras;

  NetSim network(simulation.network);
  DelayLine<PoseOnItsWay> uplink;
  DelayLine<ReceivedFrame> downlink;
  const size_t ahead = framesAhead(simulation);
  const uint64_t serverUs = uint64_t(std::llround(simulation.serverMs * 1000.0));
  uint32_t serverFrame = 0;
  for (size_t i = 0; i < path.size(); ++i) {
    const uint64_t nowUs = cameraTimeUs(i, simulation.fps);
    Pose pose;
    pose.sequence = uint32_t(i + 1); // lost poses leave gaps: the server only needs increasing numbers
    pose.clientTimeUs = nowUs;
    pose.camera = toProtocolCamera(path[i]);
    pose.predicted = toProtocolCamera(path[std::min(i + ahead, path.size() - 1)]);
    pose.viewportWidth = options.width;
    pose.viewportHeight = options.height;
    ClientFrameInfo info;
    info.index = i;
    info.count = path.size();
    info.codec = welcome->codec;
    info.poseLost = network.losePose();
    if (!info.poseLost) {
      uint64_t arrivalUs = network.uplinkArrival(nowUs);
      uplink.push(arrivalUs, {arrivalUs, pose});
    }

    // The server answers each pose that has reached it by now; its frame starts down after serverMs.
    while (auto up = uplink.popArrived(nowUs)) {
      auto frames = exchangePose(transport, up->pose, options);
      if (!frames) return frames.error();
      for (ReceivedFrame& frame : *frames)
        downlink.push(network.downlinkArrival(up->arrivalUs + serverUs), std::move(frame));
    }
    while (auto down = downlink.popArrived(nowUs)) {
      if (auto s = applyReceivedFrame(**view, transport, *down, options, info); !s) return s;
      serverFrame = down->frame.sequence;
      uint64_t takenUs = cameraTimeUs(down->frame.poseSequence - 1, simulation.fps);
      info.roundTripMs = double(nowUs - takenUs) / 1000.0;
    }
    info.serverFrame = serverFrame;
    info.framesInFlight = uint32_t(uplink.size() + downlink.size());
    info.patchesHeld = (*view)->patchCount();
    info.particlesHeld = (*view)->particleCount();
    auto image = (*view)->render(path[i], options.width, options.height);
    if (!image) return image.error();
    if (auto s = sink(info, *image); !s) return s;
  }
  transport.close();
  return Ok{};
}

} // namespace mirage::stream
