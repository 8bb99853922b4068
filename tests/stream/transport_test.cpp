// Loopback tests of the WebSocket transport (port 0: the system picks a free port).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>

#include "mirage/stream/transport.h"
#include "stream/transport_ws.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::stream;
using namespace std::chrono_literals;

namespace {

constexpr const char* kTransportToken = "correct horse battery staple";

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

Pose pose(uint32_t sequence) {
  Pose p;
  p.sequence = sequence;
  p.clientTimeUs = 1000 * sequence;
  p.camera.eye = {0.0f, 1.0f, 5.0f};
  p.predicted = p.camera;
  p.predicted.eye.x = 0.1f * float(sequence);
  p.viewportWidth = 640;
  p.viewportHeight = 480;
  return p;
}

Frame frame(uint32_t sequence, size_t atlasBytes) {
  Frame f;
  f.sequence = sequence;
  f.poseSequence = sequence;
  f.removed = {sequence};
  f.atlas.codec = AtlasCodec::ZstdTiles;
  f.atlas.width = f.atlas.height = 64;
  f.atlas.bytes.assign(atlasBytes, uint8_t(sequence));
  return f;
}

// A server that answers Hello with Welcome (sessionId = client id) and records what it sees.
class Harness {
public:
  explicit Harness(ServerConfig config = {}) {
    if (config.token.empty()) config.token = kTransportToken;
    ServerEvents events;
    events.onMessage = [this](ClientId id, Message&& message) {
      if (std::holds_alternative<Hello>(message)) {
        Welcome welcome;
        welcome.sessionId = id;
        welcome.atlasWidth = welcome.atlasHeight = 1024;
        welcome.maxMessageBytes = 1 << 16;
        server.send(id, welcome);
      }
      std::lock_guard lock(mutex);
      messages.push_back({id, std::move(message)});
      changed.notify_all();
    };
    events.onDisconnect = [this](ClientId id, const std::string& reason) {
      std::lock_guard lock(mutex);
      disconnects.push_back({id, reason});
      changed.notify_all();
    };
    events.onRefused = [this](const std::string& reason) {
      std::lock_guard lock(mutex);
      refusals.push_back(reason);
      changed.notify_all();
    };
    Status started = server.start(config, std::move(events));
    EXPECT_TRUE(started.ok()) << started.error().message;
  }
  // Before the members the events use are destroyed: stop() reports the clients it disconnects.
  ~Harness() { server.stop(); }
  std::string url() const { return "ws://127.0.0.1:" + std::to_string(server.port()) + "/"; }

  template <class Pred> bool waitFor(Pred pred, std::chrono::milliseconds timeout = 5s) {
    std::unique_lock lock(mutex);
    return changed.wait_for(lock, timeout, pred);
  }
  size_t posesFrom(ClientId id) {
    std::lock_guard lock(mutex);
    return posesFromLocked(id);
  }
  size_t posesFromLocked(ClientId id) const {
    size_t n = 0;
    for (auto& [from, m] : messages) n += from == id && std::holds_alternative<Pose>(m);
    return n;
  }

  TransportServer server;
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::pair<ClientId, Message>> messages;
  std::vector<std::pair<ClientId, std::string>> disconnects;
  std::vector<std::string> refusals;
};

ClientConfig clientConfig(const std::string& token = kTransportToken) {
  ClientConfig config;
  config.hello = Hello{token, kCapabilityZstdTiles, 640, 480, false};
  config.timeout = 5s;
  return config;
}

// Connects and checks the pose -> server and frame -> client paths both work.
void expectWorking(Harness& h, TransportClient& client, ClientId id, uint32_t sequence) {
  size_t before = h.posesFrom(id);
  ASSERT_TRUE(client.send(pose(sequence)));
  EXPECT_TRUE(h.waitFor([&] {
    for (auto& [from, m] : h.messages)
      if (from == id && std::holds_alternative<Pose>(m) && std::get<Pose>(m).sequence == sequence) return true;
    return false;
  })) << "pose "
      << sequence << " did not arrive";
  EXPECT_EQ(h.posesFrom(id), before + 1);
  ASSERT_TRUE(h.server.send(id, frame(sequence, 100)));
  Result<Message> got = client.receive(5s);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_TRUE(*got == Message(frame(sequence, 100)));
}

// The Close a refused client gets: its reason, or the receive error when none came.
std::string closeReasonOf(TransportClient& client) {
  for (int i = 0; i < 10; ++i) {
    Result<Message> m = client.receive(5s);
    if (!m) return m.error().message;
    if (const Close* close = std::get_if<Close>(&*m)) return close->reason;
  }
  return "";
}

} // namespace

TEST(StreamTransport, HelloWelcomePoseAndFrame) {
  Harness h;
  ASSERT_NE(h.server.port(), 0);
  TransportClient client;
  Result<Welcome> welcome = client.connect(h.url(), clientConfig());
  ASSERT_TRUE(welcome.ok()) << welcome.error().message;
  EXPECT_EQ(welcome->atlasWidth, 1024u);
  ClientId id = welcome->sessionId;
  ASSERT_TRUE(h.waitFor([&] { return !h.messages.empty(); }));
  {
    std::lock_guard lock(h.mutex);
    ASSERT_TRUE(std::holds_alternative<Hello>(h.messages[0].second));
    EXPECT_EQ(std::get<Hello>(h.messages[0].second).viewportWidth, 640u);
  }
  expectWorking(h, client, id, 1);
  expectWorking(h, client, id, 2);
  ASSERT_TRUE(client.send(pose(3)));
  ASSERT_TRUE(h.waitFor([&] { return h.posesFromLocked(id) == 3; }));
  {
    std::lock_guard lock(h.mutex);
    EXPECT_TRUE(h.messages.back().second == Message(pose(3)));
  }
  client.close();
  EXPECT_TRUE(h.waitFor([&] { return h.disconnects.size() == 1; }));
}

TEST(StreamTransport, StopClosesClientsAndReturns) {
  Harness h;
  TransportClient a, b;
  ASSERT_TRUE(a.connect(h.url(), clientConfig()).ok());
  ASSERT_TRUE(b.connect(h.url(), clientConfig()).ok());
  auto start = std::chrono::steady_clock::now();
  h.server.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);
  {
    std::lock_guard lock(h.mutex);
    EXPECT_EQ(h.disconnects.size(), 2u);
  }
  Result<Message> gone = a.receive(5s);
  ASSERT_FALSE(gone.ok());
  EXPECT_NE(gone.error().message.find("server stopping"), std::string::npos) << gone.error().message;
  EXPECT_FALSE(a.connected());
  for (int i = 0; i < 500 && b.connected(); ++i) std::this_thread::sleep_for(10ms);
  EXPECT_FALSE(b.connected());
  h.server.stop(); // again: nothing to do
}

TEST(StreamTransport, WrongTokenIsRefusedWithReason) {
  Harness h;
  TransportClient client;
  Result<Welcome> welcome = client.connect(h.url(), clientConfig("not the token"));
  ASSERT_FALSE(welcome.ok());
  EXPECT_NE(welcome.error().message.find("wrong token"), std::string::npos) << welcome.error().message;
  EXPECT_TRUE(h.waitFor([&] { return h.refusals.size() == 1; }));
  std::lock_guard lock(h.mutex);
  EXPECT_TRUE(h.messages.empty()) << "a refused client's Hello reached the owner";
}

TEST(StreamTransport, BadMessagesCloseOnlyThatClient) {
  ServerConfig config;
  config.maxMessageBytes = 4096;
  Harness h(config);
  TransportClient good;
  Result<Welcome> goodWelcome = good.connect(h.url(), clientConfig());
  ASSERT_TRUE(goodWelcome.ok()) << goodWelcome.error().message;
  ClientId goodId = goodWelcome->sessionId;

  std::vector<uint8_t> truncated = encodeMessage(pose(1));
  truncated.pop_back();
  std::vector<uint8_t> forgedCount = encodeMessage(pose(1));
  forgedCount[8] = 0xff; // header length no longer matches
  Hello secondHello = clientConfig().hello;
  struct Case {
    std::string name;
    std::vector<std::vector<uint8_t>> send;
    std::string reason;
  };
  std::vector<Case> cases = {
      {"garbage", {{'h', 'e', 'l', 'l', 'o'}}, "shorter than the 12-byte header"},
      {"truncated", {truncated}, "header length"},
      {"forged length", {forgedCount}, "header length"},
      {"second Hello", {encodeMessage(secondHello)}, "second Hello"},
      {"pose sequence", {encodeMessage(pose(5)), encodeMessage(pose(5))}, "Pose sequence 5 not above"},
      {"oversized", {std::vector<uint8_t>(8192, 7)}, ""},
  };
  uint32_t sequence = 1;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    TransportClient bad;
    ASSERT_TRUE(bad.connect(h.url(), clientConfig()).ok());
    for (const std::vector<uint8_t>& bytes : c.send) ASSERT_TRUE(bad.sendBytes(bytes));
    std::string reason = closeReasonOf(bad);
    EXPECT_NE(reason.find(c.reason), std::string::npos) << reason;
    for (int i = 0; i < 500 && bad.connected(); ++i) std::this_thread::sleep_for(10ms);
    EXPECT_FALSE(bad.connected()) << "the server did not close the connection";
    expectWorking(h, good, goodId, sequence++);
  }
}

TEST(StreamTransport, PoseBeforeHelloIsRefused) {
  Harness h;
  std::mutex mutex;
  std::condition_variable closed;
  std::string reason;
  std::vector<std::string> received;
  std::unique_ptr<ws::Client> raw = ws::makeClient(false);
  ws::ClientCallbacks callbacks;
  callbacks.onBinary = [&](std::string&& bytes) {
    std::lock_guard lock(mutex);
    received.push_back(std::move(bytes));
  };
  callbacks.onClosed = [&](uint16_t, const std::string& why) {
    std::lock_guard lock(mutex);
    reason = why.empty() ? "closed" : why;
    closed.notify_all();
  };
  ASSERT_TRUE(raw->open({h.url(), "", 1 << 20, 5s}, callbacks).ok());
  ASSERT_TRUE(raw->send(encodeMessage(pose(1))));
  std::unique_lock lock(mutex);
  ASSERT_TRUE(closed.wait_for(lock, 5s, [&] { return !reason.empty(); }));
  EXPECT_NE(reason.find("Pose before Hello"), std::string::npos) << reason;
  ASSERT_EQ(received.size(), 1u);
  Result<Message> close =
      decodeMessage(std::span(reinterpret_cast<const uint8_t*>(received[0].data()), received[0].size()), {}, "server");
  ASSERT_TRUE(close.ok());
  EXPECT_EQ(std::get<Close>(*close).code, CloseCode::OutOfOrder);
}

TEST(StreamTransport, IdleConnectionWithoutHelloTimesOut) {
  ServerConfig config;
  config.helloTimeout = 200ms;
  Harness h(config);
  std::mutex mutex;
  std::condition_variable closed;
  std::string reason;
  std::unique_ptr<ws::Client> raw = ws::makeClient(false);
  ws::ClientCallbacks callbacks;
  callbacks.onClosed = [&](uint16_t, const std::string& why) {
    std::lock_guard lock(mutex);
    reason = why.empty() ? "closed" : why;
    closed.notify_all();
  };
  ASSERT_TRUE(raw->open({h.url(), "", 1 << 20, 5s}, callbacks).ok());
  std::unique_lock lock(mutex);
  ASSERT_TRUE(closed.wait_for(lock, 5s, [&] { return !reason.empty(); }));
  EXPECT_NE(reason.find("no Hello within 200 ms"), std::string::npos) << reason;
}

TEST(StreamTransport, StalledClientIsBoundedAndOthersKeepWorking) {
  ServerConfig config;
  config.maxQueuedBytes = 1u << 20;
  Harness h(config);
  TransportClient stalled, other;
  Result<Welcome> stalledWelcome = stalled.connect(h.url(), clientConfig());
  Result<Welcome> otherWelcome = other.connect(h.url(), clientConfig());
  ASSERT_TRUE(stalledWelcome.ok() && otherWelcome.ok());
  stalled.pauseReading();
  std::this_thread::sleep_for(50ms);

  // Frames of 64 KiB until the server has refused for 200 ms in a row (the socket stopped draining).
  std::vector<uint8_t> bytes = encodeMessage(frame(1, 64u << 10));
  uint64_t accepted = 0, maxQueued = 0;
  int refusedInARow = 0;
  auto deadline = std::chrono::steady_clock::now() + 20s;
  while (refusedInARow < 100 && std::chrono::steady_clock::now() < deadline) {
    if (h.server.send(stalledWelcome->sessionId, bytes)) {
      accepted += bytes.size();
      refusedInARow = 0;
    } else {
      ++refusedInARow;
      std::this_thread::sleep_for(2ms);
    }
    maxQueued = std::max(maxQueued, h.server.queuedBytes(stalledWelcome->sessionId));
  }
  EXPECT_EQ(refusedInARow, 100) << "the server kept accepting frames for a client that does not read";
  EXPECT_LE(maxQueued, config.maxQueuedBytes);
  // What was accepted is the bound plus what the kernel's socket buffers took (a few MiB on loopback).
  EXPECT_LT(accepted, config.maxQueuedBytes + (64u << 20));
  expectWorking(h, other, otherWelcome->sessionId, 1);
}

TEST(StreamTransport, MaxClientsAndReconnect) {
  ServerConfig config;
  config.maxClients = 2;
  Harness h(config);
  TransportClient a, b, c;
  ASSERT_TRUE(a.connect(h.url(), clientConfig()).ok());
  Result<Welcome> bWelcome = b.connect(h.url(), clientConfig());
  ASSERT_TRUE(bWelcome.ok());
  Result<Welcome> full = c.connect(h.url(), clientConfig());
  ASSERT_FALSE(full.ok());
  EXPECT_NE(full.error().message.find("server full (2 clients)"), std::string::npos) << full.error().message;

  a.close();
  ASSERT_TRUE(h.waitFor([&] { return h.disconnects.size() == 1; }));
  Result<Welcome> again = c.connect(h.url(), clientConfig());
  ASSERT_TRUE(again.ok()) << again.error().message;
  expectWorking(h, c, again->sessionId, 1);

  // The same client object reconnects after its connection is gone.
  b.close();
  ASSERT_TRUE(h.waitFor([&] { return h.disconnects.size() == 2; }));
  Result<Welcome> bAgain = b.connect(h.url(), clientConfig());
  ASSERT_TRUE(bAgain.ok()) << bAgain.error().message;
  EXPECT_NE(bAgain->sessionId, bWelcome->sessionId);
  expectWorking(h, b, bAgain->sessionId, 1);
}

namespace {

// One HTTP request over a plain socket: the status code and the body.
std::pair<int, std::string> httpGet(uint16_t port, const std::string& target) {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  timeval timeout{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return {0, ""};
  }
  std::string request = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  (void)!::write(fd, request.data(), request.size());
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = ::read(fd, buffer, sizeof buffer)) > 0;) response.append(buffer, size_t(n));
  ::close(fd);
  if (response.rfind("HTTP/1.1 ", 0) != 0) return {0, response};
  size_t body = response.find("\r\n\r\n");
  return {std::stoi(response.substr(9, 3)), body == std::string::npos ? "" : response.substr(body + 4)};
}

} // namespace

TEST(StreamTransport, StaticFilesAndTraversal) {
  std::filesystem::path root = test::tempDir("http");
  std::filesystem::create_directories(root / "www" / "lib");
  writeFile(root / "www" / "index.html", "<p>atlas client</p>");
  writeFile(root / "www" / "client.js", "export const x = 1;");
  writeFile(root / "www" / "lib" / "atlas.js", "// atlas");
  writeFile(root / "secret.txt", "do not serve");
  std::filesystem::create_symlink(root / "secret.txt", root / "www" / "link.js");
  ServerConfig config;
  config.staticDir = root / "www";
  Harness h(config);

  EXPECT_EQ(httpGet(h.server.port(), "/"), std::make_pair(200, std::string("<p>atlas client</p>")));
  EXPECT_EQ(httpGet(h.server.port(), "/client.js?v=2"), std::make_pair(200, std::string("export const x = 1;")));
  EXPECT_EQ(httpGet(h.server.port(), "/lib/atlas.js"), std::make_pair(200, std::string("// atlas")));
  EXPECT_EQ(httpGet(h.server.port(), "/missing.js").first, 404);
  for (const char* target : {"/../secret.txt", "/%2e%2e/secret.txt", "/lib/../../secret.txt", "//etc/passwd",
                             "/.hidden", "/link.js", "/lib/", "/a\\..\\secret.txt"}) {
    std::pair<int, std::string> reply = httpGet(h.server.port(), target);
    EXPECT_TRUE(reply.first == 403 || reply.first == 400) << target << " -> " << reply.first;
    EXPECT_EQ(reply.second.find("do not serve"), std::string::npos) << target;
  }
  EXPECT_EQ(staticFilePath(root / "www", "/lib/atlas.js"),
            std::filesystem::weakly_canonical(root / "www/lib/atlas.js"));
  EXPECT_TRUE(staticFilePath(root / "www", "/../secret.txt").empty());
  EXPECT_TRUE(staticFilePath(root / "www", "/link.js").empty()) << "a symbolic link out of the directory";
  EXPECT_TRUE(staticFilePath("", "/index.html").empty());
  std::filesystem::remove_all(root);
}

namespace {

// A self-signed certificate for "localhost" (P-256 key), written as PEM files.
void makeSelfSignedCertificate(const std::filesystem::path& certFile, const std::filesystem::path& keyFile) {
  EVP_PKEY* key = EVP_EC_gen("P-256");
  ASSERT_NE(key, nullptr);
  X509* cert = X509_new();
  X509_set_version(cert, 2);
  ASN1_INTEGER_set(X509_get_serialNumber(cert), 1);
  X509_gmtime_adj(X509_getm_notBefore(cert), -60);
  X509_gmtime_adj(X509_getm_notAfter(cert), 3600);
  X509_set_pubkey(cert, key);
  X509_NAME* name = X509_get_subject_name(cert);
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC, reinterpret_cast<const unsigned char*>("localhost"), -1, -1, 0);
  X509_set_issuer_name(cert, name);
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, cert, cert, nullptr, nullptr, 0);
  for (auto [nid, value] : {std::pair{NID_subject_alt_name, "DNS:localhost,IP:127.0.0.1"},
                            std::pair{NID_basic_constraints, "critical,CA:TRUE"}}) {
    X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
    ASSERT_NE(ext, nullptr);
    X509_add_ext(cert, ext, -1);
    X509_EXTENSION_free(ext);
  }
  ASSERT_GT(X509_sign(cert, key, EVP_sha256()), 0);
  FILE* out = std::fopen(certFile.c_str(), "wb");
  PEM_write_X509(out, cert);
  std::fclose(out);
  out = std::fopen(keyFile.c_str(), "wb");
  PEM_write_PrivateKey(out, key, nullptr, nullptr, 0, nullptr, nullptr);
  std::fclose(out);
  X509_free(cert);
  EVP_PKEY_free(key);
}

} // namespace

TEST(StreamTransport, TlsRoundTrip) {
  std::filesystem::path dir = test::tempDir("tls");
  makeSelfSignedCertificate(dir / "cert.pem", dir / "key.pem");
  ServerConfig config;
  config.certFile = (dir / "cert.pem").string();
  config.keyFile = (dir / "key.pem").string();
  Harness h(config);
  std::string url = "wss://localhost:" + std::to_string(h.server.port()) + "/";

  ClientConfig trusting = clientConfig();
  trusting.caFile = config.certFile;
  TransportClient client;
  Result<Welcome> welcome = client.connect(url, trusting);
  ASSERT_TRUE(welcome.ok()) << welcome.error().message;
  expectWorking(h, client, welcome->sessionId, 1);

  // The certificate is not in the system's trust store: verification fails.
  TransportClient untrusting;
  EXPECT_FALSE(untrusting.connect(url, clientConfig()).ok());
  // Plain ws:// to a TLS port does not get through either.
  TransportClient plain;
  EXPECT_FALSE(plain.connect("ws://127.0.0.1:" + std::to_string(h.server.port()) + "/", clientConfig()).ok());
  expectWorking(h, client, welcome->sessionId, 2);
  std::filesystem::remove_all(dir);
}

TEST(StreamTransport, StartErrors) {
  TransportServer noToken;
  EXPECT_FALSE(noToken.start(ServerConfig{}, {}).ok());
  ServerConfig missingCert;
  missingCert.token = kTransportToken;
  missingCert.certFile = "/nonexistent/cert.pem";
  missingCert.keyFile = "/nonexistent/key.pem";
  TransportServer tls;
  Status status = tls.start(missingCert, {});
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.error().message.find("/nonexistent/cert.pem: file not found"), std::string::npos)
      << status.error().message;
  TransportClient client;
  Result<Welcome> badUrl = client.connect("http://127.0.0.1:1/", clientConfig());
  ASSERT_FALSE(badUrl.ok());
  EXPECT_NE(badUrl.error().message.find("not a ws:// or wss:// URL"), std::string::npos);
}

TEST(StreamTransport, TokenFile) {
  std::filesystem::path dir = test::tempDir("token");
  writeFile(dir / "token", "  s3cret-token\n\n");
  Result<std::string> token = readTokenFile(dir / "token");
  ASSERT_TRUE(token.ok()) << token.error().message;
  EXPECT_EQ(*token, "s3cret-token");
  writeFile(dir / "blank", " \n\t\n");
  Result<std::string> blank = readTokenFile(dir / "blank");
  ASSERT_FALSE(blank.ok());
  EXPECT_NE(blank.error().message.find("token file is empty"), std::string::npos);
  writeFile(dir / "long", std::string(300, 'x'));
  EXPECT_FALSE(readTokenFile(dir / "long").ok());
  Result<std::string> missing = readTokenFile(dir / "missing");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("file not found"), std::string::npos) << missing.error().message;
  std::filesystem::remove_all(dir);
}
