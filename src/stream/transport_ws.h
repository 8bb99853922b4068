#pragma once
// The WebSocket endpoints under transport.h, the only code that includes websocketpp. Debian's
// websocketpp 0.8.2 does not parse as C++20 (template-id constructors and destructors), so
// transport_ws.cpp is compiled as C++17 and this header is its C++17 boundary: plain bytes,
// ids and callbacks; decoding, authentication and ordering live in transport.cpp.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::stream::ws {

using ConnectionId = uint64_t;

struct HttpReply {
  int status = 404;
  std::string contentType = "text/plain";
  std::string body;
};

// Called on the endpoint's thread; they must not block.
struct ServerCallbacks {
  std::function<void(ConnectionId, const std::string& remote)> onOpen;
  std::function<void(ConnectionId, std::string&& bytes)> onBinary;
  std::function<void(ConnectionId, const std::string& why)> onBadFrame; // a text frame
  std::function<void(ConnectionId, uint16_t status, const std::string& reason)> onClosed;
  std::function<HttpReply(const std::string& method, const std::string& target)> onHttp;
};

struct ServerOptions {
  std::string host;
  uint16_t port = 0;
  std::string certFile, keyFile; // both set: wss
  uint64_t maxMessageBytes = 0;
  uint64_t maxQueuedBytes = 0;
};

// A WebSocket server running its asio loop on its own thread. send, queuedBytes, close and post are
// thread-safe; the callbacks run on the endpoint's thread.
class Server {
public:
  virtual ~Server() = default;
  // Listens and starts the thread; the port picked (options.port 0: a free one) is port().
  virtual Status start(const ServerOptions& options, ServerCallbacks callbacks) = 0;
  virtual uint16_t port() const = 0;
  // Queues `bytes` as one binary frame; false when the connection is gone or its queue would pass
  // maxQueuedBytes (unless `force`: the Close message before a disconnect).
  virtual bool send(ConnectionId id, std::vector<uint8_t> bytes, bool force) = 0;
  virtual uint64_t queuedBytes(ConnectionId id) const = 0;
  virtual void close(ConnectionId id, uint16_t status, const std::string& reason) = 0;
  // Runs `task` on the endpoint's thread after `delay`.
  virtual void runAfter(std::chrono::milliseconds delay, std::function<void()> task) = 0;
  // Stops listening, closes every connection (going away) and joins the thread.
  virtual void stop() = 0;
};
std::unique_ptr<Server> makeServer(bool tls);

struct ClientCallbacks {
  std::function<void(std::string&& bytes)> onBinary;
  std::function<void(uint16_t status, const std::string& reason)> onClosed; // also a failed connect
};

struct ClientOptions {
  std::string url;    // ws://host:port/path or wss://...
  std::string caFile; // wss: PEM certificates to trust ("" = the system's); the host name is verified
  uint64_t maxMessageBytes = 0;
  std::chrono::milliseconds timeout{5000};
};

class Client {
public:
  virtual ~Client() = default;
  // Connects and waits for the WebSocket handshake (options.timeout); the thread runs until close.
  virtual Status open(const ClientOptions& options, ClientCallbacks callbacks) = 0;
  virtual bool send(std::vector<uint8_t> bytes) = 0;
  // Stops reading from the socket: the server sees a peer that does not keep up.
  virtual void pauseReading() = 0;
  virtual void close(uint16_t status, const std::string& reason) = 0;
};
std::unique_ptr<Client> makeClient(bool tls);

} // namespace mirage::stream::ws
