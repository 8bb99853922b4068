#pragma once
// `mirage serve`: the stream server (docs/stream.md, "Server"). The transport's thread hands
// messages to run()'s loop; the loop answers each client's latest pose with a frame once the
// client's previous frame left the queue (a slow client gets fewer frames, latest pose wins, and
// never a growing queue), one client at a time on the one GPU.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "mirage/core/result.h"
#include "mirage/stream/session.h"
#include "mirage/stream/transport.h"

namespace mirage::stream {

struct ServeOptions {
  ServerConfig transport;              // port, token, max clients, TLS, static files
  AtlasCodec codec = AtlasCodec::H264; // preferred atlas codec; a client without it gets ZstdTiles
  ClientStreamConfig stream;           // bitrate, level bias (codec chosen per client)
  // Largest frame message sent (the client's decode limit must take it).
  uint32_t maxFrameBytes = 256u << 20;
  // Threads encoding frames while the GPU prepares the next client's (0: frame_workers.h's default,
  // a quarter of the processors within 2..8).
  uint32_t encodeWorkers = 0;
};

// One line per event (connections, refusals, per-second figures); empty: silent.
using ServeLog = std::function<void(const std::string&)>;

class StreamServer {
public:
  // Starts listening. Errors: the transport's (port in use, bad certificate, empty token).
  static Result<std::unique_ptr<StreamServer>> start(gpu::Context& context, std::unique_ptr<StreamScene> scene,
                                                     const ServeOptions& options, ServeLog log = {});
  ~StreamServer();
  uint16_t port() const;

  // Serves until `stop` becomes true (a signal handler may set it), then closes every client
  // ("server stopping") and returns. Errors: a GPU stage failing (the GPU is shared: serving stops).
  Status run(const std::atomic<bool>& stop);

  struct Impl;

private:
  explicit StreamServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::stream
