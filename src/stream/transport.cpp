// The protocol side of the transport: authentication, per-connection order and size rules, the
// client's inbox. Everything per connection runs on the transport thread (transport_ws.cpp calls
// back on it); send/queuedBytes/close go through the thread-safe ws layer.
#include "mirage/stream/transport.h"

#include <array>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <unordered_map>

#include <openssl/crypto.h>
#include <openssl/evp.h>

#include "mirage/core/input_text.h"
#include "transport_http.h"
#include "transport_ws.h"

namespace mirage::stream {

uint16_t closeStatusFor(CloseCode code) {
  switch (code) {
  case CloseCode::Normal:
    return 1000;
  case CloseCode::BadToken:
    return 1008; // policy violation
  case CloseCode::Malformed:
    return 1002; // protocol error
  case CloseCode::OutOfOrder:
    return 1002; // protocol error
  case CloseCode::TooLarge:
    return 1009; // message too big
  case CloseCode::ServerFull:
    return 1013; // try again later
  case CloseCode::HelloTimeout:
    return 1008; // policy violation
  case CloseCode::Overloaded:
    return 1013; // try again later
  case CloseCode::Unsupported:
    return 1003; // unsupported data
  }
  return 1000;
}

namespace {

using Digest = std::array<uint8_t, 32>;

// Tokens are compared as SHA-256 digests with CRYPTO_memcmp: constant time in the token's bytes
// and, unlike a plain CRYPTO_memcmp of the tokens, in its length too.
Digest tokenDigest(std::string_view token) {
  Digest digest{};
  unsigned int size = 0;
  EVP_Digest(token.data(), token.size(), digest.data(), &size, EVP_sha256(), nullptr);
  return digest;
}

struct Slot {
  std::string peer; // "client 3 (127.0.0.1:41234)"
  bool authenticated = false;
  bool closing = false;     // closed by the server: what still arrives is ignored
  std::string closedReason; // why the server closed it
  ClientMessageOrder order;
};

} // namespace

struct TransportServer::State {
  ServerConfig config;
  ServerEvents events;
  Digest token{};
  std::unordered_map<ClientId, Slot> slots; // transport thread only
};

TransportServer::TransportServer() : state_(std::make_unique<State>()) {}
TransportServer::~TransportServer() { stop(); }

Status TransportServer::start(const ServerConfig& config, ServerEvents events) {
  if (server_) return makeError("stream server", "already started");
  if (config.token.empty()) return makeError("stream server", "empty token: every client would be refused");
  if (config.certFile.empty() != config.keyFile.empty())
    return makeError("stream server", "TLS needs both a certificate and a key file");
  State& s = *state_;
  s.config = config;
  s.config.limits.maxMessageBytes = config.maxMessageBytes;
  s.events = std::move(events);
  s.token = tokenDigest(config.token);

  auto refuse = [this](ClientId id, CloseCode code, const std::string& reason) {
    State& st = *state_;
    auto it = st.slots.find(id);
    if (it == st.slots.end() || it->second.closing) return;
    it->second.closing = true;
    it->second.closedReason = reason;
    server_->send(id, encodeMessage(Close{code, reason}), true);
    server_->close(id, closeStatusFor(code), reason);
    if (!it->second.authenticated && st.events.onRefused) st.events.onRefused(reason);
  };

  ws::ServerCallbacks callbacks;
  callbacks.onOpen = [this, refuse](ws::ConnectionId id, const std::string& remote) {
    State& st = *state_;
    Slot& slot = st.slots[id];
    slot.peer = "client " + std::to_string(id) + " (" + remote + ")";
    // Connections on their way out (refused, closing) do not count.
    size_t open = 0;
    for (const auto& entry : st.slots) open += !entry.second.closing;
    if (open > st.config.maxClients) {
      refuse(id, CloseCode::ServerFull,
             slot.peer + ": server full (" + std::to_string(st.config.maxClients) + " clients)");
      return;
    }
    server_->runAfter(st.config.helloTimeout, [this, id, refuse] {
      auto it = state_->slots.find(id);
      if (it != state_->slots.end() && !it->second.authenticated)
        refuse(id, CloseCode::HelloTimeout,
               it->second.peer + ": no Hello within " + std::to_string(state_->config.helloTimeout.count()) + " ms");
    });
  };
  callbacks.onBadFrame = [this, refuse](ws::ConnectionId id, const std::string& why) {
    auto it = state_->slots.find(id);
    if (it != state_->slots.end()) refuse(id, CloseCode::Malformed, it->second.peer + ": " + why);
  };
  callbacks.onBinary = [this, refuse](ws::ConnectionId id, std::string&& bytes) {
    State& st = *state_;
    auto it = st.slots.find(id);
    if (it == st.slots.end() || it->second.closing) return;
    Slot& slot = it->second;
    std::span<const uint8_t> span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    Result<Message> message = decodeMessage(span, st.config.limits, slot.peer);
    if (!message) {
      bool tooLarge = bytes.size() > st.config.limits.maxMessageBytes;
      refuse(id, tooLarge ? CloseCode::TooLarge : CloseCode::Malformed, message.error().message);
      return;
    }
    Status ordered = acceptClientMessage(slot.order, *message, slot.peer);
    if (!ordered) {
      refuse(id, CloseCode::OutOfOrder, ordered.error().message);
      return;
    }
    if (Hello* hello = std::get_if<Hello>(&*message)) {
      Digest given = tokenDigest(hello->token);
      if (CRYPTO_memcmp(given.data(), st.token.data(), given.size()) != 0) {
        refuse(id, CloseCode::BadToken, slot.peer + ": wrong token");
        return;
      }
      slot.authenticated = true;
    } else if (std::holds_alternative<Close>(*message)) {
      slot.closing = true;
      slot.closedReason = slot.peer + ": closed by the client: " + escapeInput(std::get<Close>(*message).reason, 200);
      server_->close(id, closeStatusFor(CloseCode::Normal), "");
      if (!slot.authenticated) return;
    }
    if (st.events.onMessage) st.events.onMessage(id, std::move(*message));
  };
  callbacks.onClosed = [this](ws::ConnectionId id, uint16_t status, const std::string& reason) {
    State& st = *state_;
    auto it = st.slots.find(id);
    if (it == st.slots.end()) return;
    Slot slot = std::move(it->second);
    st.slots.erase(it);
    if (!slot.authenticated) return;
    std::string why = slot.closedReason;
    if (why.empty()) {
      why = slot.peer + ": connection closed (" + std::to_string(status);
      if (!reason.empty()) why += ", " + escapeInput(reason, 200);
      why += ")";
    }
    if (st.events.onDisconnect) st.events.onDisconnect(id, why);
  };
  callbacks.onHttp = [this](const std::string& method, const std::string& target) {
    return serveStaticFile(state_->config.staticDir, method, target);
  };

  ws::ServerOptions options;
  options.host = config.host;
  options.port = config.port;
  options.certFile = config.certFile;
  options.keyFile = config.keyFile;
  options.maxMessageBytes = config.maxMessageBytes;
  options.maxQueuedBytes = config.maxQueuedBytes;
  server_ = ws::makeServer(!config.certFile.empty());
  Status started = server_->start(options, std::move(callbacks));
  if (!started) server_.reset();
  return started;
}

uint16_t TransportServer::port() const { return server_ ? server_->port() : 0; }

bool TransportServer::send(ClientId client, std::span<const uint8_t> bytes) {
  return server_ && server_->send(client, std::vector<uint8_t>(bytes.begin(), bytes.end()), false);
}

bool TransportServer::send(ClientId client, const Message& message) {
  return server_ && server_->send(client, encodeMessage(message), false);
}

uint64_t TransportServer::queuedBytes(ClientId client) const { return server_ ? server_->queuedBytes(client) : 0; }

void TransportServer::close(ClientId client, CloseCode code, const std::string& reason) {
  if (!server_) return;
  // On the transport thread, which owns the connection's state.
  server_->runAfter(std::chrono::milliseconds(0), [this, client, code, reason] {
    auto it = state_->slots.find(client);
    if (it == state_->slots.end() || it->second.closing) return;
    it->second.closing = true;
    it->second.closedReason = it->second.peer + ": closed by the server: " + reason;
    server_->send(client, encodeMessage(Close{code, reason}), true);
    server_->close(client, closeStatusFor(code), reason);
  });
}

void TransportServer::stop() {
  if (server_) server_->stop();
}

// The client's receiving side, shared with the ws thread that fills it.
struct TransportClient::Inbox {
  std::string url;
  DecodeLimits limits;
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<Message> messages;
  bool closed = false;
  bool badMessage = false; // the client closes the connection
  std::string error;       // why the connection ended, or the message that did not decode

  void push(std::string&& bytes) {
    std::span<const uint8_t> span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    Result<Message> message = decodeMessage(span, limits, url);
    {
      std::lock_guard lock(mutex);
      if (closed) return;
      if (!message) {
        closed = true;
        badMessage = true;
        error = message.error().message;
      } else {
        if (const Close* close = std::get_if<Close>(&*message))
          error = url + ": closed by the server: " + escapeInput(close->reason, 200);
        messages.push_back(std::move(*message));
      }
    }
    arrived.notify_all();
  }
  void end(uint16_t status, const std::string& reason) {
    {
      std::lock_guard lock(mutex);
      if (!closed && error.empty())
        error = url + ": connection closed (" + std::to_string(status) + " " + escapeInput(reason, 200) + ")";
      closed = true;
    }
    arrived.notify_all();
  }
};

TransportClient::TransportClient() = default;
TransportClient::~TransportClient() {
  if (connected()) close();
}

Result<Welcome> TransportClient::connect(const std::string& url, const ClientConfig& config) {
  if (client_ && connected()) close();
  client_.reset();
  bool tls = url.starts_with("wss://");
  if (!tls && !url.starts_with("ws://")) return makeError(quoteInput(url, 200), "not a ws:// or wss:// URL");
  url_ = url;
  inbox_ = std::make_shared<Inbox>();
  inbox_->url = url;
  inbox_->limits = config.limits;
  ws::ClientCallbacks callbacks;
  callbacks.onBinary = [inbox = inbox_](std::string&& bytes) { inbox->push(std::move(bytes)); };
  callbacks.onClosed = [inbox = inbox_](uint16_t status, const std::string& reason) { inbox->end(status, reason); };
  ws::ClientOptions options{url, config.caFile, config.limits.maxMessageBytes, config.timeout};
  client_ = ws::makeClient(tls);
  Status opened = client_->open(options, std::move(callbacks));
  if (!opened) {
    client_.reset();
    return opened.error();
  }
  client_->send(encodeMessage(config.hello));
  Result<Message> answer = receive(config.timeout);
  if (!answer) return answer.error();
  if (Welcome* welcome = std::get_if<Welcome>(&*answer)) return std::move(*welcome);
  if (const Close* refused = std::get_if<Close>(&*answer)) {
    client_.reset(); // waits (briefly) for the server's close to complete
    return makeError(url, "refused: " + escapeInput(refused->reason, 200));
  }
  close(CloseCode::OutOfOrder, "expected Welcome");
  return makeError(url, "expected Welcome, got " + messageTypeName(messageType(*answer)));
}

bool TransportClient::send(const Message& message) { return client_ && client_->send(encodeMessage(message)); }

bool TransportClient::sendBytes(std::vector<uint8_t> bytes) { return client_ && client_->send(std::move(bytes)); }

Result<Message> TransportClient::receive(std::chrono::milliseconds timeout) {
  if (!inbox_) return makeError("stream client", "not connected");
  Inbox& in = *inbox_;
  std::unique_lock lock(in.mutex);
  in.arrived.wait_for(lock, timeout, [&] { return !in.messages.empty() || in.closed; });
  if (!in.messages.empty()) {
    Message message = std::move(in.messages.front());
    in.messages.pop_front();
    return message;
  }
  if (in.closed) {
    std::string error = in.error;
    bool bad = in.badMessage;
    lock.unlock();
    if (bad && client_) client_->close(closeStatusFor(CloseCode::Malformed), "bad message");
    return Error{error};
  }
  return makeError(url_, "no message within " + std::to_string(timeout.count()) + " ms");
}

bool TransportClient::connected() const {
  if (!client_ || !inbox_) return false;
  std::lock_guard lock(inbox_->mutex);
  return !inbox_->closed;
}

void TransportClient::pauseReading() {
  if (client_) client_->pauseReading();
}

void TransportClient::close(CloseCode code, const std::string& reason) {
  if (!client_) return;
  client_->send(encodeMessage(Close{code, reason}));
  client_->close(closeStatusFor(code), reason);
}

Result<std::string> readTokenFile(const std::filesystem::path& path) {
  Result<std::string> text = readInputText(path, 4096, "token file");
  if (!text) return text;
  std::string& token = *text;
  const char* space = " \t\r\n";
  size_t first = token.find_first_not_of(space);
  if (first == std::string::npos) return makeError(path.string(), "token file is empty");
  token = token.substr(first, token.find_last_not_of(space) - first + 1);
  uint32_t maxBytes = DecodeLimits{}.maxTokenBytes;
  if (token.size() > maxBytes)
    return makeError(path.string(), "token of " + std::to_string(token.size()) + " bytes, more than the " +
                                        std::to_string(maxBytes) + " a Hello may carry");
  return token;
}

} // namespace mirage::stream
