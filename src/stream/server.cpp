// The stream server's loop (server.h; docs/stream.md, "Server").
#include "mirage/stream/server.h"

#include <condition_variable>
#include <deque>
#include <mutex>
#include <unordered_map>

#include <fmt/format.h>

#include "frame_workers.h"

namespace mirage::stream {

namespace {

// What the transport's thread hands over. Hellos and disconnects come once per connection (the
// queue is bounded by the connections the transport admits); poses are kept per client, the
// latest replacing an unanswered one, so a client sending poses fast costs no memory.
struct Event {
  ClientId client = 0;
  std::optional<Hello> hello; // else a disconnect
  std::string reason;
};

} // namespace

struct StreamServer::Impl {
  gpu::Context& ctx;
  std::unique_ptr<StreamScene> scene;
  ServeOptions options;
  ServeLog log;
  TransportServer transport;

  std::mutex mutex;
  std::condition_variable wake;
  std::deque<Event> events;
  std::unordered_map<ClientId, Pose> poses;
  bool changed = false; // a pose arrived or a frame was finished since the loop last looked
  // What a worker did with a frame: sent it (bytes), found it too large for the client's queue, or
  // failed to make it (the encoder: serving stops, as for a GPU stage). Guarded by mutex until the
  // loop takes it.
  struct Finished {
    std::optional<Error> error;
    bool sent = false;
    size_t bytes = 0;
  };
  std::unordered_map<ClientId, Finished> finished;

  struct Client {
    std::unique_ptr<ClientStream> stream;
    uint64_t frames = 0, bytes = 0;
    bool inFlight = false; // a worker finishes this client's frame (until the loop takes it)
  };
  std::unordered_map<ClientId, Client> clients;
  // Declared after clients: joined before the streams its jobs use are destroyed.
  FrameWorkers workers;

  Impl(gpu::Context& c, std::unique_ptr<StreamScene> s, const ServeOptions& o, ServeLog l)
      : ctx(c), scene(std::move(s)), options(o), log(std::move(l)), workers(frameWorkerCount(o.encodeWorkers)) {}

  void say(const std::string& line) const {
    if (log) log(line);
  }

  void push(Event e) {
    {
      std::lock_guard lock(mutex);
      events.push_back(std::move(e));
    }
    wake.notify_one();
  }

  ServerEvents transportEvents() {
    ServerEvents ev;
    ev.onMessage = [this](ClientId id, Message&& m) {
      if (auto* hello = std::get_if<Hello>(&m)) {
        push({id, std::move(*hello), {}});
      } else if (auto* pose = std::get_if<Pose>(&m)) {
        {
          std::lock_guard lock(mutex);
          poses[id] = *pose;
          changed = true;
        }
        wake.notify_one();
      }
    };
    ev.onDisconnect = [this](ClientId id, const std::string& reason) { push({id, std::nullopt, reason}); };
    ev.onRefused = [this](const std::string& reason) { say(fmt::format("refused: {}", reason)); };
    return ev;
  }

  AtlasCodec chooseCodec(uint32_t capabilities) const {
    bool h264 = capabilities & kCapabilityH264, tiles = capabilities & kCapabilityZstdTiles,
         jpeg = capabilities & kCapabilityJpegTiles;
    if (options.codec == AtlasCodec::H264 && h264) return AtlasCodec::H264;
    if (tiles) return AtlasCodec::ZstdTiles;
    if (h264) return AtlasCodec::H264;
    if (jpeg) return AtlasCodec::JpegTiles; // browsers without WebCodecs
    return AtlasCodec::None;
  }

  void welcome(ClientId id, const Hello& hello) {
    AtlasCodec codec = chooseCodec(hello.capabilities);
    if (codec == AtlasCodec::None) {
      transport.close(id, CloseCode::Unsupported,
                      "no atlas codec in common (the server sends zstd tiles, H.264 and JPEG tiles)");
      return;
    }
    ClientStreamConfig config = options.stream;
    config.codec = codec;
    config.zstdPatches = (hello.capabilities & kCapabilityZstdPatches) != 0;
    auto stream = ClientStream::create(*scene, config);
    if (!stream) {
      transport.close(id, CloseCode::Unsupported, stream.error().message);
      return;
    }
    Welcome w = sceneWelcome(*scene, codec);
    w.sessionId = id;
    w.maxMessageBytes = options.transport.maxMessageBytes;
    if (!transport.send(id, w)) return;
    clients[id] = Client{std::move(*stream)};
    say(fmt::format("client {} joined ({}x{}, {})", id, hello.viewportWidth, hello.viewportHeight,
                    codec == AtlasCodec::H264        ? "H.264"
                    : codec == AtlasCodec::JpegTiles ? "JPEG tiles"
                                                     : "zstd tiles"));
  }

  // The GPU half of the frame answering `pose` here; the rest (encoding, the patch section,
  // sending) on a worker. Errors: a GPU stage failing.
  Status answer(ClientId id, const Pose& pose) {
    auto it = clients.find(id);
    if (it == clients.end()) return Ok{}; // gone, or refused at Hello
    ClientStream* stream = it->second.stream.get();
    if (Status s = stream->prepareFrame(*scene, pose); !s) return s;
    it->second.inFlight = true;
    (void)workers.submit([this, id, stream] {
      Finished done;
      auto frame = stream->finishFrame(*scene);
      if (!frame) {
        done.error = frame.error();
      } else {
        std::vector<uint8_t> bytes = encodeMessage(*frame);
        done.bytes = bytes.size();
        done.sent = bytes.size() <= options.maxFrameBytes && transport.send(id, bytes);
      }
      {
        std::lock_guard lock(mutex);
        finished[id] = std::move(done);
        changed = true;
      }
      wake.notify_all();
    });
    return Ok{};
  }

  // Waits until the workers finished the frames in flight of client `id` (nullopt: of every client).
  void waitFinished(std::optional<ClientId> id) {
    auto pending = [&] {
      for (const auto& [cid, c] : clients)
        if (c.inFlight && (!id || cid == *id) && !finished.count(cid)) return true;
      return false;
    };
    std::unique_lock lock(mutex);
    wake.wait(lock, [&] { return !pending(); });
  }

  // Takes the frames the workers finished. Errors: a frame that could not be made (serving stops).
  Status collect() {
    std::unordered_map<ClientId, Finished> done;
    {
      std::lock_guard lock(mutex);
      done.swap(finished);
    }
    Status result = Ok{};
    for (auto& [id, f] : done) {
      auto it = clients.find(id);
      if (it == clients.end()) continue;
      it->second.inFlight = false;
      if (f.error) {
        result = Error{fmt::format("client {}: {}", id, f.error->message)};
      } else if (!f.sent) {
        transport.close(id, CloseCode::Overloaded, "a frame did not fit the client's queue");
        clients.erase(it);
      } else {
        it->second.frames++;
        it->second.bytes += f.bytes;
      }
    }
    return result;
  }
};

StreamServer::StreamServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
StreamServer::~StreamServer() { impl_->transport.stop(); }

Result<std::unique_ptr<StreamServer>> StreamServer::start(gpu::Context& context, std::unique_ptr<StreamScene> scene,
                                                          const ServeOptions& options, ServeLog log) {
  auto impl = std::make_unique<Impl>(context, std::move(scene), options, std::move(log));
  if (auto s = impl->transport.start(options.transport, impl->transportEvents()); !s) return s.error();
  return std::unique_ptr<StreamServer>(new StreamServer(std::move(impl)));
}

uint16_t StreamServer::port() const { return impl_->transport.port(); }

Status StreamServer::run(const std::atomic<bool>& stop) {
  Impl& d = *impl_;
  Status result = Ok{};
  bool waiting = false; // a pose waits for its client's queue to drain, which no event announces
  while (!stop.load() && result) {
    std::deque<Event> events;
    std::vector<std::pair<ClientId, Pose>> due;
    {
      std::unique_lock lock(d.mutex);
      d.wake.wait_for(lock, std::chrono::milliseconds(waiting ? 1 : 5), [&] { return !d.events.empty() || d.changed; });
      d.changed = false;
      events.swap(d.events);
    }
    result = d.collect();
    if (!result) break;
    for (Event& e : events) {
      if (e.hello) {
        d.welcome(e.client, *e.hello);
      } else if (auto it = d.clients.find(e.client); it != d.clients.end()) {
        if (it->second.inFlight) d.waitFinished(e.client); // its worker uses the stream
        d.say(fmt::format("client {} left after {} frames, {:.1f} MB: {}", e.client, it->second.frames,
                          it->second.bytes / 1e6, e.reason));
        d.clients.erase(it);
      }
    }
    {
      // A pose is answered once the client's previous frame is finished and has left the queue;
      // until then a newer pose replaces it.
      std::lock_guard lock(d.mutex);
      waiting = false;
      for (auto it = d.poses.begin(); it != d.poses.end();) {
        auto client = d.clients.find(it->first);
        bool busy = client != d.clients.end() && client->second.inFlight;
        if (!busy && d.transport.queuedBytes(it->first) == 0) {
          due.emplace_back(it->first, it->second);
          it = d.poses.erase(it);
        } else {
          waiting = waiting || !busy;
          ++it;
        }
      }
    }
    for (const auto& [id, pose] : due) {
      if (Status s = d.answer(id, pose); !s) {
        result = Error{fmt::format("client {}: {}", id, s.error().message)};
        break;
      }
    }
  }
  d.waitFinished(std::nullopt);
  if (Status s = d.collect(); result && !s) result = s;
  d.transport.stop();
  return result;
}

} // namespace mirage::stream
