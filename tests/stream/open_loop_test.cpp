// The open-loop client under a simulated network (client.h runSimulatedPathClient, net_sim.h) end to
// end on loopback: a server and the client in one process (two Vulkan devices: a queue is not
// shared between threads), small images of gen:city:2.
#include <atomic>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "loopback_server.h"
#include "mirage/stream/client.h"
#include "mirage/stream/server.h"

namespace mirage {
namespace {

constexpr uint32_t kOpenLoopWidth = 160, kOpenLoopHeight = 90;
constexpr char kScene[] = "gen:city:2";

// A lossless (or H.264) server of a scene on a free port: test::StreamTestServer (loopback_server.h).
using LoopbackServer = test::StreamTestServer;

stream::StreamClientOptions clientOptions(const LoopbackServer& server) {
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = test::kStreamToken;
  options.width = kOpenLoopWidth;
  options.height = kOpenLoopHeight;
  options.capabilities = stream::kCapabilityZstdTiles;
  options.timeout = std::chrono::milliseconds(20000); // lavapipe on a busy machine; a hang still ends
  return options;
}

struct Run {
  std::vector<stream::ClientFrameInfo> infos;
  std::vector<ImageRGBA8> images;
};

// The images and figures of one run along `path`: lock-step without `simulation`, else open loop.
Result<Run> runClient(gpu::Context& ctx, const LoopbackServer& server, const std::string& path,
                      const stream::SimulatedClientOptions* simulation) {
  Run run;
  auto sink = [&](const stream::ClientFrameInfo& info, const render::RenderOutput& out) -> Status {
    run.infos.push_back(info);
    run.images.push_back(out.srgb);
    return Ok{};
  };
  Status s = simulation ? stream::runSimulatedPathClient(ctx, clientOptions(server), path, *simulation, sink)
                        : stream::runPathClient(ctx, clientOptions(server), path, sink);
  if (!s) return s.error();
  return run;
}

// Every pixel the same: the background of a client that holds nothing.
bool isUniform(const ImageRGBA8& image) {
  for (size_t i = 4; i < image.pixels.size(); ++i)
    if (image.pixels[i] != image.pixels[i % 4]) return false;
  return true;
}

} // namespace

class StreamOpenLoop : public test::GpuTest {};

namespace {

TEST_F(StreamOpenLoop, WithoutLatencyEqualsLockStep) {
  LoopbackServer server(kScene, stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  auto lockStep = runClient(context(), server, "orbit:3", nullptr);
  ASSERT_TRUE(lockStep) << lockStep.error().message;
  stream::SimulatedClientOptions simulation;
  auto openLoop = runClient(context(), server, "orbit:3", &simulation);
  ASSERT_TRUE(openLoop) << openLoop.error().message;
  ASSERT_EQ(openLoop->images.size(), 3u);
  ASSERT_EQ(lockStep->images.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_FALSE(isUniform(openLoop->images[i])) << "camera " << i;
    EXPECT_TRUE(openLoop->images[i].pixels == lockStep->images[i].pixels) << "camera " << i;
    EXPECT_EQ(openLoop->infos[i].serverFrame, lockStep->infos[i].serverFrame) << "camera " << i;
    EXPECT_EQ(openLoop->infos[i].frameBytes, lockStep->infos[i].frameBytes) << "camera " << i;
    EXPECT_EQ(openLoop->infos[i].framesApplied, 1u);
    EXPECT_EQ(openLoop->infos[i].framesInFlight, 0u);
    EXPECT_EQ(openLoop->infos[i].roundTripMs, 0.0);
  }
}

// 50 ms round trip at 60 Hz: each frame arrives 3 client frames after its pose.
TEST_F(StreamOpenLoop, WithLatencyEveryCameraIsDrawnFromTheFramesArrived) {
  LoopbackServer server(kScene, stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::SimulatedClientOptions simulation;
  simulation.network.roundTripMs = 50;
  auto run = runClient(context(), server, "orbit:6", &simulation);
  ASSERT_TRUE(run) << run.error().message;
  ASSERT_EQ(run->images.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    const stream::ClientFrameInfo& info = run->infos[i];
    EXPECT_EQ(info.index, i);
    EXPECT_EQ(info.framesInFlight, std::min<uint32_t>(uint32_t(i) + 1, 3)) << "camera " << i;
    if (i < 3) { // nothing arrived yet: the background
      EXPECT_EQ(info.framesApplied, 0u) << "camera " << i;
      EXPECT_EQ(info.patchesHeld, 0u) << "camera " << i;
      EXPECT_TRUE(isUniform(run->images[i])) << "camera " << i;
    } else { // the frame answering camera i - 3
      EXPECT_EQ(info.framesApplied, 1u) << "camera " << i;
      EXPECT_EQ(info.serverFrame, uint32_t(i - 2)) << "camera " << i;
      EXPECT_NEAR(info.roundTripMs, 50.0, 0.01) << "camera " << i;
      EXPECT_GT(info.patchesHeld, 0u) << "camera " << i;
      EXPECT_GT(info.frameBytes, 0u) << "camera " << i;
      EXPECT_FALSE(isUniform(run->images[i])) << "camera " << i;
    }
  }
}

TEST_F(StreamOpenLoop, AllPosesLostLeavesTheFirstFrameAndEnds) {
  LoopbackServer server(kScene, stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::SimulatedClientOptions simulation;
  simulation.network.roundTripMs = 50;
  simulation.network.poseLoss = 1.0;
  auto run = runClient(context(), server, "orbit:5", &simulation);
  ASSERT_TRUE(run) << run.error().message;
  ASSERT_EQ(run->images.size(), 5u);
  uint32_t applied = 0;
  for (size_t i = 0; i < 5; ++i) {
    const stream::ClientFrameInfo& info = run->infos[i];
    EXPECT_EQ(info.poseLost, i > 0) << "camera " << i;
    applied += info.framesApplied;
    EXPECT_EQ(info.serverFrame, i < 3 ? 0u : 1u) << "camera " << i;
    EXPECT_EQ(info.framesInFlight, i < 3 ? 1u : 0u) << "camera " << i;
  }
  EXPECT_EQ(applied, 1u);
  EXPECT_FALSE(isUniform(run->images[4])); // drawn from the first frame
}

TEST_F(StreamOpenLoop, SameSeedSameRun) {
  LoopbackServer server(kScene, stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::SimulatedClientOptions simulation;
  simulation.network.roundTripMs = 30;
  simulation.network.jitterMs = 25;
  simulation.network.poseLoss = 0.3;
  simulation.network.seed = 7;
  auto first = runClient(context(), server, "orbit:8", &simulation);
  ASSERT_TRUE(first) << first.error().message;
  auto second = runClient(context(), server, "orbit:8", &simulation);
  ASSERT_TRUE(second) << second.error().message;
  ASSERT_EQ(first->images.size(), 8u);
  ASSERT_EQ(second->images.size(), 8u);
  size_t lost = 0;
  for (size_t i = 0; i < 8; ++i) {
    const stream::ClientFrameInfo &a = first->infos[i], &b = second->infos[i];
    lost += a.poseLost;
    EXPECT_EQ(a.poseLost, b.poseLost) << "camera " << i;
    EXPECT_EQ(a.serverFrame, b.serverFrame) << "camera " << i;
    EXPECT_EQ(a.framesApplied, b.framesApplied) << "camera " << i;
    EXPECT_EQ(a.framesInFlight, b.framesInFlight) << "camera " << i;
    EXPECT_EQ(a.frameBytes, b.frameBytes) << "camera " << i;
    EXPECT_EQ(a.roundTripMs, b.roundTripMs) << "camera " << i;
    EXPECT_TRUE(first->images[i].pixels == second->images[i].pixels) << "camera " << i;
  }
  EXPECT_GT(lost, 0u) << "seed 7 loses no pose of 8 at 30 %: the test shows nothing about losses";
}

TEST_F(StreamOpenLoop, BadNetworkConfigurationIsRefusedBeforeConnecting) {
  stream::StreamClientOptions options;
  options.url = "ws://127.0.0.1:1/"; // nothing listens: a connection attempt would fail differently
  options.token = test::kStreamToken;
  stream::SimulatedClientOptions simulation;
  simulation.network.poseLoss = 2.0;
  Status s = stream::runSimulatedPathClient(
      context(), options, "orbit:2", simulation,
      [](const stream::ClientFrameInfo&, const render::RenderOutput&) { return Status(Ok{}); });
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("pose loss"), std::string::npos) << s.error().message;
}

} // namespace
} // namespace mirage
