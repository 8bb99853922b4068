#pragma once
// WebSocket transport of the stream protocol (docs/stream.md, "Transport and security"): a server
// that authenticates clients (first message Hello with the shared token), enforces the protocol's
// order and size rules per connection and bounds what it queues for each client, and a client that
// connects, says Hello and waits for Welcome. Plain ws://, or wss:// (TLS, OpenSSL) when the server
// is given a certificate and key. The server also serves the browser client's static files.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/stream/protocol.h"

namespace mirage::stream {

namespace ws {
class Server;
class Client;
} // namespace ws

using ClientId = uint64_t;

// The WebSocket close status that goes with a Close message's code (1000, 1008, 1002, 1009, 1013, ...).
uint16_t closeStatusFor(CloseCode code);

struct ServerConfig {
  std::string host = "127.0.0.1";               // the address to listen on ("0.0.0.0": every interface)
  uint16_t port = 0;                            // 0: a free port, reported by TransportServer::port()
  std::string token;                            // what Hello must carry (start() refuses an empty one)
  uint32_t maxClients = 8;                      // open connections, authenticated or not
  uint32_t maxMessageBytes = 64u << 10;         // largest message a client may send (Hello, Pose, Close are small)
  uint64_t maxQueuedBytes = 64u << 20;          // per client: send() refuses past it
  std::chrono::milliseconds helloTimeout{5000}; // a connection without a valid Hello is closed after it
  std::filesystem::path staticDir;              // GET / -> index.html, GET /x.js -> x.js inside it; empty: no files
  std::string certFile, keyFile;                // both set: wss (TLS); PEM files
  DecodeLimits limits; // for client messages; maxMessageBytes above overrides limits.maxMessageBytes
};

// Called on the transport's thread: keep them short (hand work to another thread) and do not call
// stop() from them. send() and close() may be called from them.
struct ServerEvents {
  // Hello (once per client, after its token was accepted: answer with Welcome), then Pose and Close.
  std::function<void(ClientId, Message&&)> onMessage;
  // A client that had said Hello is gone; `reason` says why (one line).
  std::function<void(ClientId, const std::string& reason)> onDisconnect;
  // A connection refused or closed before its Hello was accepted (wrong token, full, timeout, bad message).
  std::function<void(const std::string& reason)> onRefused;
};

class TransportServer {
public:
  TransportServer();
  ~TransportServer(); // stop()
  TransportServer(const TransportServer&) = delete;
  TransportServer& operator=(const TransportServer&) = delete;

  // Listens and starts the transport thread. Errors: bad address, port in use, unreadable certificate.
  Status start(const ServerConfig& config, ServerEvents events);
  uint16_t port() const;
  // Thread-safe. Queues one message for `client`; false when the client is gone or its queue would
  // pass maxQueuedBytes: the caller skips or merges (the next frame carries the latest state). A
  // message larger than maxQueuedBytes is never accepted.
  bool send(ClientId client, std::span<const uint8_t> bytes);
  bool send(ClientId client, const Message& message);
  // Bytes queued for `client` and not yet handed to its socket (0 when gone). At most maxQueuedBytes;
  // the socket's own buffers and up to 256 KiB being written come on top.
  uint64_t queuedBytes(ClientId client) const;
  // Sends Close{code, reason} and closes the connection (what was still queued is dropped).
  void close(ClientId client, CloseCode code, const std::string& reason);
  // Closes every connection ("server stopping") and joins the transport thread. Idempotent.
  void stop();

private:
  struct State;
  std::unique_ptr<State> state_;
  std::unique_ptr<ws::Server> server_;
};

struct ClientConfig {
  Hello hello;        // token, capabilities, viewport, stereo
  std::string caFile; // wss: PEM certificates to trust ("" = the system's); the host name is verified
  std::chrono::milliseconds timeout{5000}; // connect and wait for Welcome
  DecodeLimits limits;                     // for server messages (Frame is large: raise maxMessageBytes)
};

class TransportClient {
public:
  TransportClient();
  ~TransportClient(); // closes (Close Normal) if connected
  TransportClient(const TransportClient&) = delete;
  TransportClient& operator=(const TransportClient&) = delete;

  // Connects to ws://host:port/ or wss://..., sends Hello and waits for Welcome. A Close instead
  // (wrong token, server full) is an error carrying its reason. Drops any earlier connection first.
  Result<Welcome> connect(const std::string& url, const ClientConfig& config);
  // Thread-safe. False when not connected.
  bool send(const Message& message);
  bool sendBytes(std::vector<uint8_t> bytes); // as is, for tests of the server's checks
  // The next message from the server, waiting up to `timeout`. Errors: nothing within the timeout,
  // the connection closed (with the server's Close reason), a message that does not decode (the
  // client then closes the connection).
  Result<Message> receive(std::chrono::milliseconds timeout);
  bool connected() const;
  // Stops reading from the socket (messages stay in the server's queue and the kernel's buffers).
  void pauseReading();
  // Sends Close{code, reason} and closes.
  void close(CloseCode code = CloseCode::Normal, const std::string& reason = "client closing");

private:
  struct Inbox;
  std::shared_ptr<Inbox> inbox_;
  std::unique_ptr<ws::Client> client_;
  std::string url_;
};

// A token file: its text (at most 4 KiB), leading and trailing whitespace trimmed; an error for an
// unreadable or empty file, or a token longer than a Hello may carry.
Result<std::string> readTokenFile(const std::filesystem::path& path);

// The file that GET `target` serves from `dir`: "/" -> index.html, "/name.ext" or "/sub/name.ext" made
// of letters, digits, '.', '-', '_' (no segment starting with '.'); an empty path when the target is
// not such a name or resolves (symbolic links included) outside `dir`. Exposed for tests.
std::filesystem::path staticFilePath(const std::filesystem::path& dir, std::string_view target);

} // namespace mirage::stream
