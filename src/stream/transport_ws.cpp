// websocketpp endpoints (C++17, see transport_ws.h). Threading: every websocketpp call runs on the
// endpoint's own thread; other threads only post work to its io_context. Outgoing frames wait in a
// per-connection queue of ours and are handed to websocketpp only while websocketpp holds less than
// kHandOffBytes, so queuedBytes sees (nearly) everything a slow peer makes the server hold and the
// bound in send() holds memory, not just a counter.
#include "transport_ws.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <unordered_map>

#include <openssl/ssl.h>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio.hpp>
#include <websocketpp/config/asio_client.hpp>
#include <websocketpp/server.hpp>

#include "mirage/core/input_text.h"

namespace mirage::stream::ws {
namespace {

namespace wsp = websocketpp;
using Hdl = wsp::connection_hdl;
using Opcode = wsp::frame::opcode::value;

// What websocketpp may hold of one connection's frames beyond the one being written.
constexpr size_t kHandOffBytes = 256u << 10;
// How often a connection with frames waiting looks at websocketpp's buffer again.
constexpr std::chrono::milliseconds kPumpInterval{1};
// How long stop() and a client's destructor wait for close handshakes before dropping the sockets.
constexpr std::chrono::milliseconds kCloseGrace{500};
// WebSocket close reasons are at most 123 bytes (RFC 6455 5.5.1).
constexpr size_t kMaxCloseReason = 123;

// Cut at a UTF-8 character boundary: a reason cut inside a character is not valid UTF-8 and the
// peer would fail the connection instead of reading it.
std::string closeReason(const std::string& reason) {
  if (reason.size() <= kMaxCloseReason) return reason;
  size_t n = kMaxCloseReason;
  while (n > 0 && (uint8_t(reason[n]) & 0xc0) == 0x80) --n;
  return reason.substr(0, n);
}

Status loadTlsFiles(asio::ssl::context& context, const std::string& certFile, const std::string& keyFile) {
  for (const std::string* file : {&certFile, &keyFile}) {
    std::string problem = inputFileProblem(*file);
    if (!problem.empty()) return makeError(*file, problem);
  }
  asio::error_code ec;
  context.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                          asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1,
                      ec);
  context.use_certificate_chain_file(certFile, ec);
  if (ec) return makeError(certFile, "not a PEM certificate chain (" + ec.message() + ")");
  context.use_private_key_file(keyFile, asio::ssl::context::pem, ec);
  if (ec) return makeError(keyFile, "not a PEM private key for the certificate (" + ec.message() + ")");
  return Ok{};
}

// One connection's outgoing frames. The counters are read by any thread; the rest is the endpoint thread's.
struct Connection {
  Hdl hdl;
  std::atomic<uint64_t> queued{0}; // accepted by send, not yet handed to websocketpp
  std::atomic<uint64_t> handed{0}; // websocketpp's buffered amount when last looked at
  std::atomic<bool> open{true};
  std::deque<std::vector<uint8_t>> frames;
  bool pumpScheduled = false;
};

template <bool Tls> class ServerImpl final : public Server {
  using Config = std::conditional_t<Tls, wsp::config::asio_tls, wsp::config::asio>;
  using Endpoint = wsp::server<Config>;

public:
  ~ServerImpl() override { stop(); }

  Status start(const ServerOptions& options, ServerCallbacks callbacks) override {
    options_ = options;
    callbacks_ = std::move(callbacks);
    std::error_code ec;
    endpoint_.clear_access_channels(wsp::log::alevel::all);
    endpoint_.clear_error_channels(wsp::log::elevel::all);
    endpoint_.init_asio(ec);
    if (ec) return makeError("stream server", "cannot start the network loop (" + ec.message() + ")");
    if constexpr (Tls) {
      tls_ = std::make_shared<asio::ssl::context>(asio::ssl::context::tls_server);
      Status loaded = loadTlsFiles(*tls_, options.certFile, options.keyFile);
      if (!loaded) return loaded;
      endpoint_.set_tls_init_handler([this](Hdl) { return tls_; });
    }
    endpoint_.set_reuse_addr(true);
    endpoint_.set_max_message_size(size_t(options.maxMessageBytes));
    endpoint_.set_open_handler([this](Hdl hdl) { onOpen(hdl); });
    endpoint_.set_message_handler([this](Hdl hdl, typename Endpoint::message_ptr m) { onMessage(hdl, m); });
    endpoint_.set_close_handler([this](Hdl hdl) { onEnd(hdl); });
    endpoint_.set_fail_handler([this](Hdl hdl) { onEnd(hdl); });
    endpoint_.set_http_handler([this](Hdl hdl) { onHttp(hdl); });

    asio::ip::address address = asio::ip::make_address(options.host, ec);
    std::string where = options.host + ":" + std::to_string(options.port);
    if (ec) return makeError("stream server", "'" + options.host + "' is not an IP address");
    endpoint_.listen(asio::ip::tcp::endpoint(address, options.port), ec);
    if (ec) return makeError("stream server", "cannot listen on " + where + " (" + ec.message() + ")");
    endpoint_.start_accept(ec);
    if (ec) return makeError("stream server", "cannot accept on " + where + " (" + ec.message() + ")");
    asio::error_code local;
    port_ = endpoint_.get_local_endpoint(local).port();
    thread_ = std::thread([this] { endpoint_.run(); });
    return Ok{};
  }

  uint16_t port() const override { return port_; }

  bool send(ConnectionId id, std::vector<uint8_t> bytes, bool force) override {
    std::shared_ptr<Connection> c = find(id);
    if (!c || !c->open) return false;
    uint64_t size = bytes.size();
    if (!force) {
      uint64_t queued = c->queued.load();
      do {
        if (queued + c->handed.load() + size > options_.maxQueuedBytes) return false;
      } while (!c->queued.compare_exchange_weak(queued, queued + size));
    }
    asio::post(endpoint_.get_io_service(), [this, c, force, frame = std::move(bytes)]() mutable {
      if (force) { // ahead of the queue: the Close message, right before the close frame
        handOver(*c, frame);
        return;
      }
      c->frames.push_back(std::move(frame));
      pump(c);
    });
    return true;
  }

  uint64_t queuedBytes(ConnectionId id) const override {
    std::shared_ptr<Connection> c = find(id);
    return c ? c->queued.load() + c->handed.load() : 0;
  }

  void close(ConnectionId id, uint16_t status, const std::string& reason) override {
    std::shared_ptr<Connection> c = find(id);
    if (!c) return;
    asio::post(endpoint_.get_io_service(), [this, c, status, text = closeReason(reason)] {
      dropFrames(*c);
      std::error_code ec;
      endpoint_.close(c->hdl, status, text, ec); // a connection already closing ignores it
    });
  }

  void runAfter(std::chrono::milliseconds delay, std::function<void()> task) override {
    asio::post(endpoint_.get_io_service(), [this, delay, task = std::move(task)]() mutable {
      auto timer = std::make_shared<asio::steady_timer>(endpoint_.get_io_service(), delay);
      timer->async_wait([timer, task = std::move(task)](const std::error_code& ec) {
        if (!ec) task();
      });
    });
  }

  void stop() override {
    if (!thread_.joinable()) return;
    asio::post(endpoint_.get_io_service(), [this] {
      std::error_code ec;
      endpoint_.stop_listening(ec);
      for (auto& [id, c] : snapshot()) {
        dropFrames(*c);
        endpoint_.close(c->hdl, wsp::close::status::going_away, "server stopping", ec);
      }
      waitForClosed(std::chrono::steady_clock::now() + kCloseGrace);
    });
    thread_.join();
  }

private:
  std::shared_ptr<Connection> find(ConnectionId id) const {
    std::lock_guard lock(mutex_);
    auto it = connections_.find(id);
    return it == connections_.end() ? nullptr : it->second;
  }
  std::vector<std::pair<ConnectionId, std::shared_ptr<Connection>>> snapshot() const {
    std::lock_guard lock(mutex_);
    return {connections_.begin(), connections_.end()};
  }

  // Stops the loop once every connection has closed or the grace period is over.
  void waitForClosed(std::chrono::steady_clock::time_point deadline) {
    bool empty = false;
    {
      std::lock_guard lock(mutex_);
      empty = connections_.empty();
    }
    if (empty || std::chrono::steady_clock::now() >= deadline) {
      endpoint_.stop();
      return;
    }
    auto timer = std::make_shared<asio::steady_timer>(endpoint_.get_io_service(), std::chrono::milliseconds(10));
    timer->async_wait([this, timer, deadline](const std::error_code&) { waitForClosed(deadline); });
  }

  void dropFrames(Connection& c) {
    for (const std::vector<uint8_t>& frame : c.frames) c.queued -= frame.size();
    c.frames.clear();
  }

  void handOver(Connection& c, const std::vector<uint8_t>& frame) {
    std::error_code ec;
    typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(c.hdl, ec);
    if (!ec) con->send(frame.data(), frame.size(), wsp::frame::opcode::binary);
  }

  // Hands queued frames to websocketpp while it holds little, and looks again soon while frames
  // wait or websocketpp still holds some (its buffer empties as its writes complete).
  void pump(const std::shared_ptr<Connection>& c) {
    std::error_code ec;
    typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(c->hdl, ec);
    if (ec || !c->open || con->get_state() != wsp::session::state::open) {
      dropFrames(*c);
      c->handed = 0;
      return;
    }
    while (!c->frames.empty() && con->get_buffered_amount() < kHandOffBytes) {
      const std::vector<uint8_t>& frame = c->frames.front();
      ec = con->send(frame.data(), frame.size(), wsp::frame::opcode::binary);
      c->queued -= frame.size();
      c->frames.pop_front();
      if (ec) break;
    }
    c->handed = con->get_buffered_amount();
    if ((c->frames.empty() && c->handed == 0) || c->pumpScheduled) return;
    c->pumpScheduled = true;
    auto timer = std::make_shared<asio::steady_timer>(endpoint_.get_io_service(), kPumpInterval);
    timer->async_wait([this, timer, c](const std::error_code&) {
      c->pumpScheduled = false;
      pump(c);
    });
  }

  void onOpen(Hdl hdl) {
    ConnectionId id = nextId_++;
    auto c = std::make_shared<Connection>();
    c->hdl = hdl;
    {
      std::lock_guard lock(mutex_);
      connections_[id] = c;
    }
    ids_[hdl] = id;
    std::error_code ec;
    std::string remote = endpoint_.get_con_from_hdl(hdl, ec)->get_remote_endpoint();
    if (callbacks_.onOpen) callbacks_.onOpen(id, remote);
  }

  void onMessage(Hdl hdl, typename Endpoint::message_ptr message) {
    auto it = ids_.find(hdl);
    if (it == ids_.end()) return;
    if (message->get_opcode() != wsp::frame::opcode::binary) {
      if (callbacks_.onBadFrame) callbacks_.onBadFrame(it->second, "a text frame (messages are binary frames)");
      return;
    }
    if (callbacks_.onBinary) callbacks_.onBinary(it->second, std::move(message->get_raw_payload()));
  }

  void onEnd(Hdl hdl) {
    auto it = ids_.find(hdl);
    if (it == ids_.end()) return; // failed before it opened: never announced
    ConnectionId id = it->second;
    ids_.erase(it);
    std::shared_ptr<Connection> c;
    {
      std::lock_guard lock(mutex_);
      c = connections_[id];
      connections_.erase(id);
    }
    c->open = false;
    dropFrames(*c);
    c->handed = 0;
    std::error_code ec;
    typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(hdl, ec);
    uint16_t status = con->get_local_close_code();
    std::string reason = con->get_local_close_reason();
    if (reason.empty()) reason = con->get_remote_close_reason();
    if (reason.empty() && con->get_ec()) reason = con->get_ec().message();
    if (callbacks_.onClosed) callbacks_.onClosed(id, status, reason);
  }

  void onHttp(Hdl hdl) {
    std::error_code ec;
    typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(hdl, ec);
    if (ec) return;
    HttpReply reply;
    if (callbacks_.onHttp) reply = callbacks_.onHttp(con->get_request().get_method(), con->get_resource());
    con->set_status(wsp::http::status_code::value(reply.status));
    con->replace_header("Content-Type", reply.contentType);
    con->replace_header("X-Content-Type-Options", "nosniff");
    con->set_body(reply.body);
  }

  Endpoint endpoint_;
  ServerOptions options_;
  ServerCallbacks callbacks_;
  std::shared_ptr<asio::ssl::context> tls_;
  std::thread thread_;
  uint16_t port_ = 0;
  ConnectionId nextId_ = 1;                               // endpoint thread
  std::map<Hdl, ConnectionId, std::owner_less<Hdl>> ids_; // endpoint thread
  mutable std::mutex mutex_;                              // guards connections_
  std::unordered_map<ConnectionId, std::shared_ptr<Connection>> connections_;
};

template <bool Tls> class ClientImpl final : public Client {
  using Config = std::conditional_t<Tls, wsp::config::asio_tls_client, wsp::config::asio_client>;
  using Endpoint = wsp::client<Config>;

public:
  ~ClientImpl() override {
    if (!thread_.joinable()) return;
    close(wsp::close::status::going_away, "client closing");
    {
      std::unique_lock lock(mutex_);
      changed_.wait_for(lock, kCloseGrace, [this] { return state_ == State::Closed; });
    }
    endpoint_.stop();
    thread_.join();
  }

  Status open(const ClientOptions& options, ClientCallbacks callbacks) override {
    callbacks_ = std::move(callbacks);
    std::error_code ec;
    endpoint_.clear_access_channels(wsp::log::alevel::all);
    endpoint_.clear_error_channels(wsp::log::elevel::all);
    endpoint_.init_asio(ec);
    if (ec) return makeError(options.url, "cannot start the network loop (" + ec.message() + ")");
    endpoint_.set_max_message_size(size_t(options.maxMessageBytes));
    if constexpr (Tls) {
      std::string host = wsp::uri(options.url).get_host();
      std::string caFile = options.caFile;
      endpoint_.set_tls_init_handler([host, caFile](Hdl) {
        auto context = std::make_shared<asio::ssl::context>(asio::ssl::context::tls_client);
        std::error_code e;
        context->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                                 asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                                 asio::ssl::context::no_tlsv1_1,
                             e);
        if (caFile.empty())
          context->set_default_verify_paths(e);
        else
          context->load_verify_file(caFile, e);
        context->set_verify_mode(asio::ssl::verify_peer, e);
        context->set_verify_callback(asio::ssl::host_name_verification(host), e);
        return context;
      });
      endpoint_.set_socket_init_handler([host](Hdl, asio::ssl::stream<asio::ip::tcp::socket>& socket) {
        SSL_set_tlsext_host_name(socket.native_handle(), host.c_str()); // SNI
      });
      if (!caFile.empty()) {
        std::string problem = inputFileProblem(caFile);
        if (!problem.empty()) return makeError(caFile, problem);
      }
    }
    typename Endpoint::connection_ptr con = endpoint_.get_connection(options.url, ec);
    if (ec) return makeError(options.url, "cannot connect (" + ec.message() + ")");
    hdl_ = con->get_handle();
    con->set_open_handler([this](Hdl) { setState(State::Open); });
    con->set_message_handler([this](Hdl, typename Endpoint::message_ptr m) {
      if (callbacks_.onBinary) callbacks_.onBinary(std::move(m->get_raw_payload()));
    });
    con->set_close_handler([this](Hdl hdl) { onEnd(hdl); });
    con->set_fail_handler([this](Hdl hdl) { onEnd(hdl); });
    endpoint_.connect(con);
    thread_ = std::thread([this] { endpoint_.run(); });

    std::unique_lock lock(mutex_);
    if (!changed_.wait_for(lock, options.timeout, [this] { return state_ != State::Connecting; }))
      return makeError(options.url, "no WebSocket handshake within " + std::to_string(options.timeout.count()) + " ms");
    if (state_ == State::Closed) return makeError(options.url, "cannot connect (" + failure_ + ")");
    return Ok{};
  }

  bool send(std::vector<uint8_t> bytes) override {
    if (!isOpen()) return false;
    asio::post(endpoint_.get_io_service(), [this, frame = std::move(bytes)] {
      std::error_code ec;
      endpoint_.send(hdl_, frame.data(), frame.size(), wsp::frame::opcode::binary, ec);
    });
    return true;
  }

  void pauseReading() override {
    asio::post(endpoint_.get_io_service(), [this] {
      std::error_code ec;
      typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(hdl_, ec);
      if (!ec) con->pause_reading();
    });
  }

  void close(uint16_t status, const std::string& reason) override {
    asio::post(endpoint_.get_io_service(), [this, status, text = closeReason(reason)] {
      std::error_code ec;
      endpoint_.close(hdl_, status, text, ec);
    });
  }

private:
  enum class State { Connecting, Open, Closed };

  bool isOpen() {
    std::lock_guard lock(mutex_);
    return state_ == State::Open;
  }
  void setState(State state) {
    {
      std::lock_guard lock(mutex_);
      state_ = state;
    }
    changed_.notify_all();
  }

  void onEnd(Hdl hdl) {
    std::error_code ec;
    typename Endpoint::connection_ptr con = endpoint_.get_con_from_hdl(hdl, ec);
    uint16_t status = con->get_remote_close_code();
    std::string reason = con->get_remote_close_reason();
    if (reason.empty() && con->get_ec()) reason = con->get_ec().message();
    if (reason.empty()) reason = "connection closed";
    {
      std::lock_guard lock(mutex_);
      failure_ = reason;
    }
    setState(State::Closed);
    if (callbacks_.onClosed) callbacks_.onClosed(status, reason);
  }

  Endpoint endpoint_;
  ClientCallbacks callbacks_;
  Hdl hdl_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  State state_ = State::Connecting;
  std::string failure_;
};

} // namespace

std::unique_ptr<Server> makeServer(bool tls) {
  if (tls) return std::make_unique<ServerImpl<true>>();
  return std::make_unique<ServerImpl<false>>();
}

std::unique_ptr<Client> makeClient(bool tls) {
  if (tls) return std::make_unique<ClientImpl<true>>();
  return std::make_unique<ClientImpl<false>>();
}

} // namespace mirage::stream::ws
