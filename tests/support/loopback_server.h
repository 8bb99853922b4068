#pragma once
// A stream server on a free loopback port, serving a scene on its own thread and its own Vulkan
// context (a queue is not shared between threads), for tests of clients. Header-only: include it
// from tests that link mirage_stream.
#include <atomic>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "mirage/gpu/context.h"
#include "mirage/stream/server.h"

namespace mirage::test {

// The token the test servers ask of their clients.
inline constexpr char kStreamToken[] = "stream-test-secret";

inline gpu::Context& streamServerContext() {
  static std::unique_ptr<gpu::Context> context = [] {
    gpu::ContextOptions options;
    options.validation = true;
    auto r = gpu::Context::create(options);
    if (!r) std::abort();
    return std::move(r).value();
  }();
  return *context;
}

struct StreamTestServer {
  std::unique_ptr<stream::StreamServer> server;
  std::atomic<bool> stop{false};
  std::thread thread;
  Status result = Ok{};

  // `particles`: an effect file streamed with the scene (empty: none).
  StreamTestServer(const std::string& input, stream::AtlasCodec codec, const std::string& token,
                   uint32_t atlasSize = 1024, const std::string& particles = "") {
    stream::StreamSceneOptions so;
    so.input = input;
    so.atlasSize = atlasSize;
    so.particles = particles;
    auto scene = stream::openStreamScene(streamServerContext(), so);
    EXPECT_TRUE(scene) << scene.error().message;
    if (!scene) return;
    stream::ServeOptions options;
    options.transport.token = token;
    options.codec = codec;
    auto s = stream::StreamServer::start(streamServerContext(), std::move(*scene), options);
    EXPECT_TRUE(s) << s.error().message;
    if (!s) return;
    server = std::move(*s);
    thread = std::thread([this] { result = server->run(stop); });
  }
  ~StreamTestServer() {
    stop = true;
    if (thread.joinable()) thread.join();
    EXPECT_TRUE(result) << result.error().message;
    EXPECT_EQ(streamServerContext().validationIssues(), 0u);
  }
  std::string url() const { return fmt::format("ws://127.0.0.1:{}/", server->port()); }
};

} // namespace mirage::test
