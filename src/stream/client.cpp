// The path-following network client (client.h; docs/stream.md, "Client").
#include "mirage/stream/client.h"

#include <fmt/format.h>

#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"
#include "mirage/stream/transport.h"

namespace mirage::stream {

Status runPathClient(gpu::Context& context, const StreamClientOptions& options, const std::string& pathArgument,
                     const ClientFrameSink& sink) {
  using Clock = std::chrono::steady_clock;
  TransportClient transport;
  ClientConfig config;
  config.hello.token = options.token;
  config.hello.capabilities = options.capabilities;
  config.hello.viewportWidth = options.width;
  config.hello.viewportHeight = options.height;
  config.caFile = options.caFile;
  config.timeout = options.timeout;
  config.limits.maxMessageBytes = options.maxFrameBytes;
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
  uint32_t sequence = 0;
  for (size_t i = 0; i < path.size(); ++i) {
    Pose pose;
    pose.sequence = ++sequence;
    pose.clientTimeUs = uint64_t(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
            .count());
    pose.camera = pose.predicted = toProtocolCamera(path[i]);
    pose.viewportWidth = options.width;
    pose.viewportHeight = options.height;
    auto sent = Clock::now();
    if (!transport.send(pose)) return Error{fmt::format("{}: connection lost", options.url)};
    ClientFrameInfo info;
    info.index = i;
    info.count = path.size();
    info.codec = welcome->codec;
    for (;;) { // frames answering earlier poses may come first: apply each, stop at this pose's
      auto message = transport.receive(options.timeout);
      if (!message) return message.error();
      if (auto* close = std::get_if<Close>(&*message))
        return Error{fmt::format("{}: server closed the connection: {}", options.url, close->reason)};
      auto* frame = std::get_if<Frame>(&*message);
      if (!frame)
        return Error{fmt::format("{}: unexpected {} message", options.url, messageTypeName(messageType(*message)))};
      if (auto s = (*view)->apply(*frame); !s) {
        transport.close(CloseCode::Malformed, s.error().message);
        return Error{fmt::format("{}: {}", options.url, s.error().message)};
      }
      info.serverFrame = frame->sequence;
      info.atlasBytes += frame->atlas.bytes.size();
      info.frameBytes += encodeMessage(*frame).size();
      info.framesApplied++;
      if (frame->poseSequence >= pose.sequence) break;
    }
    info.roundTripMs = std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
    info.patchesHeld = (*view)->patchCount();
    auto image = (*view)->render(path[i], options.width, options.height);
    if (!image) return image.error();
    if (auto s = sink(info, *image); !s) return s;
  }
  transport.close();
  return Ok{};
}

} // namespace mirage::stream
