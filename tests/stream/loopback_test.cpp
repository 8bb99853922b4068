// Shading Atlas Streaming end to end on loopback: a server and a native client in one process (two
// Vulkan devices: a queue is not shared between threads), along an orbit, against the forward
// renderer's image of the same cameras.
#include <atomic>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "loopback_server.h"
#include "mirage/core/image_metrics.h"
#include "mirage/runtime/scene.h"
#include "mirage/stream/client.h"
#include "mirage/stream/server.h"
#include "mirage/stream/video.h"

namespace mirage {
namespace {

constexpr uint32_t kLoopbackWidth = 320, kLoopbackHeight = 180;

// A lossless (or H.264) server of a scene on a free port: test::StreamTestServer (loopback_server.h).
using LoopbackServer = test::StreamTestServer;

// The client's frames along orbit:3 and the forward renderer's of the same cameras.
void expectMatchesLocal(gpu::Context& ctx, const std::string& input, stream::AtlasCodec codec, uint32_t capabilities,
                        double minSsim) {
  LoopbackServer server(input, codec, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = test::kStreamToken;
  options.width = kLoopbackWidth;
  options.height = kLoopbackHeight;
  options.capabilities = capabilities;
  std::vector<ImageRGBA8> streamed;
  std::vector<stream::ClientFrameInfo> infos;
  Status s = stream::runPathClient(ctx, options, "orbit:3",
                                   [&](const stream::ClientFrameInfo& info, const render::RenderOutput& out) -> Status {
                                     streamed.push_back(out.srgb);
                                     infos.push_back(info);
                                     return Ok{};
                                   });
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(streamed.size(), 3u);

  auto local = runtime::Scene::open(ctx, {.input = input});
  ASSERT_TRUE(local) << local.error().message;
  auto cameras = render::orbitPath((*local)->bounds(), float(kLoopbackWidth) / kLoopbackHeight, 3);
  for (size_t i = 0; i < cameras.size(); ++i) {
    runtime::View view;
    view.camera = cameras[i];
    view.width = kLoopbackWidth;
    view.height = kLoopbackHeight;
    auto frame = (*local)->render(view);
    ASSERT_TRUE(frame) << frame.error().message;
    double ssim = mirage::ssim(streamed[i], frame->srgb), psnr = mirage::psnr(streamed[i], frame->srgb);
    EXPECT_GE(ssim, minSsim) << "camera " << i << " PSNR " << psnr;
    std::printf("camera %zu: SSIM %.4f PSNR %.2f dB, %zu patches, %.1f KB atlas\n", i, ssim, psnr, infos[i].patchesHeld,
                infos[i].atlasBytes / 1024.0);
    EXPECT_GT(infos[i].patchesHeld, 0u);
    EXPECT_EQ(infos[i].codec, codec);
  }
}

} // namespace

class StreamLoopback : public test::GpuTest {};

namespace {

TEST_F(StreamLoopback, LosslessClientMatchesLocalRendering) {
  expectMatchesLocal(context(), "gen:city:2", stream::AtlasCodec::ZstdTiles, stream::kCapabilityZstdTiles, 0.98);
}

TEST_F(StreamLoopback, H264ClientMatchesLocalRendering) {
  expectMatchesLocal(context(), "gen:city:2", stream::AtlasCodec::H264,
                     stream::kCapabilityH264 | stream::kCapabilityZstdTiles, 0.98);
}

TEST_F(StreamLoopback, WrongTokenIsRefusedWithItsReason) {
  LoopbackServer server("gen:blob:1", stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = "not-the-token";
  Status s =
      stream::runPathClient(context(), options, "orbit:1",
                            [](const stream::ClientFrameInfo&, const render::RenderOutput&) { return Status(Ok{}); });
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("token"), std::string::npos) << s.error().message;
}

TEST_F(StreamLoopback, ReconnectGetsAFreshSession) {
  LoopbackServer server("gen:blob:1", stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = test::kStreamToken;
  options.width = 160;
  options.height = 90;
  options.capabilities = stream::kCapabilityZstdTiles;
  for (int round = 0; round < 2; ++round) {
    size_t frames = 0, firstPatches = 0;
    Status s = stream::runPathClient(context(), options, "orbit:2",
                                     [&](const stream::ClientFrameInfo& info, const render::RenderOutput&) -> Status {
                                       if (frames++ == 0) firstPatches = info.patchesHeld;
                                       return Ok{};
                                     });
    ASSERT_TRUE(s) << "round " << round << ": " << s.error().message;
    EXPECT_EQ(frames, 2u);
    EXPECT_GT(firstPatches, 0u) << "round " << round;
  }
}

TEST_F(StreamLoopback, ClientsAtOnceEachGetTheirFrames) {
  // Three H.264 clients with a pose out each at the same time: the server prepares them in turn on
  // the GPU while workers encode; each frame answers its client's pose and decodes at the atlas
  // size (stacked alpha: twice its height). A fourth client leaves with its frame being made.
  LoopbackServer server("gen:city:2", stream::AtlasCodec::H264, test::kStreamToken, 512);
  ASSERT_TRUE(server.server);
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = test::kStreamToken;
  options.width = 160;
  options.height = 90;
  options.capabilities = stream::kCapabilityH264;
  options.timeout = std::chrono::milliseconds(60000);
  stream::ClientConfig config = stream::transportConfig(options);
  constexpr size_t kClients = 3;
  std::vector<std::unique_ptr<stream::TransportClient>> clients;
  std::vector<stream::VideoDecoder> decoders;
  Bounds bounds;
  for (size_t k = 0; k < kClients + 1; ++k) {
    clients.push_back(std::make_unique<stream::TransportClient>());
    auto welcome = clients.back()->connect(options.url, config);
    ASSERT_TRUE(welcome) << welcome.error().message;
    bounds = Bounds{welcome->sceneMin, welcome->sceneMax};
    auto decoder = stream::VideoDecoder::create();
    ASSERT_TRUE(decoder);
    decoders.push_back(std::move(*decoder));
  }
  auto cameras = render::orbitPath(bounds, 16.0f / 9.0f, 6);
  for (uint32_t round = 1; round <= 2; ++round) {
    for (size_t k = 0; k < (round == 1 ? kClients + 1 : kClients); ++k) {
      stream::Pose pose;
      pose.sequence = round;
      pose.camera = pose.predicted = stream::toProtocolCamera(cameras[(k + round) % cameras.size()]);
      pose.viewportWidth = options.width;
      pose.viewportHeight = options.height;
      ASSERT_TRUE(clients[k]->send(pose));
    }
    if (round == 1) clients[kClients]->close(); // gone before (or while) its frame is made
    for (size_t k = 0; k < kClients; ++k) {
      auto message = clients[k]->receive(std::chrono::milliseconds(60000));
      ASSERT_TRUE(message) << "client " << k << ": " << message.error().message;
      auto* frame = std::get_if<stream::Frame>(&*message);
      ASSERT_TRUE(frame) << "client " << k;
      EXPECT_EQ(frame->poseSequence, round);
      EXPECT_EQ(frame->sequence, round);
      auto decoded = decoders[k].decode(frame->atlas.bytes);
      ASSERT_TRUE(decoded) << decoded.error().message;
      EXPECT_TRUE(*decoded) << "client " << k << " round " << round;
      EXPECT_EQ(decoders[k].width(), 512u);
      EXPECT_EQ(decoders[k].height(), 1024u);
    }
  }
}

} // namespace
} // namespace mirage
