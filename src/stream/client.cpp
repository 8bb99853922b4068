// The path-following network client (client.h; docs/stream.md, "Client").
#include "mirage/stream/client.h"

#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"
#include "mirage/stream/transport.h"

namespace mirage::stream {

ClientConfig transportConfig(const StreamClientOptions& options) {
  ClientConfig config;
  config.hello.token = options.token;
  config.hello.capabilities = options.capabilities | kCapabilityZstdPatches;
  config.hello.viewportWidth = options.width;
  config.hello.viewportHeight = options.height;
  config.hello.stereo = options.stereoIpd.has_value();
  config.caFile = options.caFile;
  config.timeout = options.timeout;
  config.limits.maxMessageBytes = options.maxFrameBytes;
  return config;
}

std::array<render::Camera, 2> clientEyes(const render::Camera& camera, float ipd) {
  return render::stereoEyes(camera, ipd);
}

Pose clientPose(uint32_t sequence, const render::Camera& current, const render::Camera& predicted, uint32_t width,
                uint32_t height, std::optional<float> stereoIpd) {
  Pose pose;
  pose.sequence = sequence;
  pose.clientTimeUs = uint64_t(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
  if (stereoIpd) {
    auto eyes = clientEyes(predicted, *stereoIpd);
    pose.camera = toProtocolCamera(eyes[0]);
    pose.predicted = toProtocolCamera(eyes[1]);
  } else {
    pose.camera = toProtocolCamera(current);
    pose.predicted = toProtocolCamera(predicted);
  }
  pose.viewportWidth = width;
  pose.viewportHeight = height;
  return pose;
}

render::Camera extrapolateCamera(const render::Camera& previous, const render::Camera& current, double stepSeconds,
                                 double aheadSeconds) {
  if (!(stepSeconds > 0.0) || !(aheadSeconds > 0.0)) return current;
  const float k = float(aheadSeconds / stepSeconds);
  render::Camera predicted = current;
  predicted.eye = current.eye + (current.eye - previous.eye) * k;
  predicted.target = current.target + (current.target - previous.target) * k;
  return predicted;
}

ImageRGBA8 sideBySide(const ImageRGBA8& left, const ImageRGBA8& right) {
  ImageRGBA8 out;
  out.width = left.width + right.width;
  out.height = std::max(left.height, right.height);
  out.pixels.assign(size_t(out.width) * out.height * 4, 0);
  for (uint32_t y = 0; y < left.height; ++y) std::memcpy(out.at(0, y), left.at(0, y), size_t(left.width) * 4);
  for (uint32_t y = 0; y < right.height; ++y)
    std::memcpy(out.at(left.width, y), right.at(0, y), size_t(right.width) * 4);
  return out;
}

Result<std::vector<ReceivedFrame>> exchangePose(TransportClient& transport, const Pose& pose,
                                                const StreamClientOptions& options) {
  if (!transport.send(pose)) return Error{fmt::format("{}: connection lost", options.url)};
  std::vector<ReceivedFrame> frames;
  for (;;) {
    auto message = transport.receive(options.timeout);
    if (!message) return message.error();
    if (auto* close = std::get_if<Close>(&*message))
      return Error{fmt::format("{}: server closed the connection: {}", options.url, close->reason)};
    auto* frame = std::get_if<Frame>(&*message);
    if (!frame)
      return Error{fmt::format("{}: unexpected {} message", options.url, messageTypeName(messageType(*message)))};
    uint64_t bytes = encodeMessage(*frame).size();
    bool answer = frame->poseSequence >= pose.sequence;
    frames.push_back({std::move(*frame), bytes});
    if (answer) return frames;
  }
}

Status applyReceivedFrame(StreamView& view, TransportClient& transport, const ReceivedFrame& received,
                          const StreamClientOptions& options, ClientFrameInfo& info) {
  if (auto s = view.apply(received.frame); !s) {
    transport.close(CloseCode::Malformed, s.error().message);
    return Error{fmt::format("{}: {}", options.url, s.error().message)};
  }
  info.serverFrame = received.frame.sequence;
  info.framesApplied++;
  info.frameBytes += received.bytes;
  info.atlasBytes += received.frame.atlas.bytes.size();
  return Ok{};
}

Status runPathClient(gpu::Context& context, const StreamClientOptions& options, const std::string& pathArgument,
                     const ClientFrameSink& sink) {
  using Clock = std::chrono::steady_clock;
  if (options.stereoIpd)
    if (auto s = render::validateIpd(*options.stereoIpd); !s) return s;
  TransportClient transport;
  auto welcome = transport.connect(options.url, transportConfig(options));
  if (!welcome) return welcome.error();
  auto view = StreamView::create(context, *welcome);
  if (!view) return view.error();
  Bounds bounds;
  bounds.add(welcome->sceneMin);
  bounds.add(welcome->sceneMax);
  auto cameras = render::cameraPathArgument(pathArgument, bounds, float(options.width) / float(options.height));
  if (!cameras) return cameras.error();
  const std::vector<render::Camera>& path = *cameras;
  uint32_t sequence = 0;
  for (size_t i = 0; i < path.size(); ++i) {
    Pose pose = clientPose(++sequence, path[i], path[i], options.width, options.height, options.stereoIpd);
    auto sent = Clock::now();
    ClientFrameInfo info;
    info.index = i;
    info.count = path.size();
    info.codec = welcome->codec;
    auto frames = exchangePose(transport, pose, options);
    if (!frames) return frames.error();
    for (const ReceivedFrame& frame : *frames)
      if (auto s = applyReceivedFrame(**view, transport, frame, options, info); !s) return s;
    info.roundTripMs = std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
    info.patchesHeld = (*view)->patchCount();
    info.particlesHeld = (*view)->particleCount();
    if (options.stereoIpd) {
      auto eyes = clientEyes(path[i], *options.stereoIpd);
      auto left = (*view)->render(eyes[0], options.width, options.height);
      if (!left) return left.error();
      auto right = (*view)->render(eyes[1], options.width, options.height);
      if (!right) return right.error();
      render::RenderOutput both;
      both.srgb = sideBySide(left->srgb, right->srgb);
      if (auto s = sink(info, both); !s) return s;
      continue;
    }
    auto image = (*view)->render(path[i], options.width, options.height);
    if (!image) return image.error();
    if (auto s = sink(info, *image); !s) return s;
  }
  transport.close();
  return Ok{};
}

} // namespace mirage::stream
