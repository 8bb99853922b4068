// `mirage client --stereo --record` through the stream: each half of the 2W x H image equals what
// a mono client streams and draws for that eye (the server sees the eyes as Pose.camera and
// Pose.predicted), and the halves differ from each other.
#include <algorithm>
#include <filesystem>

#include <unistd.h>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "loopback_server.h"
#include "mirage/core/image_metrics.h"
#include "mirage/render/camera.h"
#include "mirage/stream/client.h"
#include "mirage/stream/transport.h"

namespace mirage {
namespace {

constexpr uint32_t kStereoWidth = 160, kStereoHeight = 90;
constexpr float kIpd = 0.5f; // gen:city:2 spans tens of units: a visible parallax

ImageRGBA8 half(const ImageRGBA8& image, uint32_t x0, uint32_t width) {
  ImageRGBA8 out{width, image.height, std::vector<uint8_t>(size_t(width) * image.height * 4)};
  for (uint32_t y = 0; y < image.height; ++y) std::copy_n(image.at(x0, y), size_t(width) * 4, out.at(0, y));
  return out;
}

std::vector<ImageRGBA8> streamPath(const stream::StreamClientOptions& options, const std::string& path) {
  std::vector<ImageRGBA8> images;
  Status s = stream::runPathClient(test::gpuContext(), options, path,
                                   [&](const stream::ClientFrameInfo&, const render::RenderOutput& out) -> Status {
                                     images.push_back(out.srgb);
                                     return Ok{};
                                   });
  EXPECT_TRUE(s) << s.error().message;
  return images;
}

TEST(ClientPose, PredictionExtrapolatesEyeAndTargetLinearly) {
  render::Camera previous, current;
  previous.eye = {0, 1, 5};
  previous.target = {0, 1, 0};
  current.eye = {1, 1, 5}; // 1 unit along +x in 0.1 s
  current.target = {1, 1, -1};
  current.fovYDegrees = 50.0f;
  render::Camera p = stream::extrapolateCamera(previous, current, 0.1, 0.05);
  EXPECT_NEAR(p.eye.x, 1.5f, 1e-5f);
  EXPECT_NEAR(p.eye.z, 5.0f, 1e-5f);
  EXPECT_NEAR(p.target.x, 1.5f, 1e-5f);
  EXPECT_NEAR(p.target.z, -1.5f, 1e-5f);
  EXPECT_EQ(p.fovYDegrees, 50.0f);
  // No step, no round trip measured yet, or no motion: the current camera.
  EXPECT_EQ(stream::extrapolateCamera(previous, current, 0.0, 0.05).eye, current.eye);
  EXPECT_EQ(stream::extrapolateCamera(previous, current, 0.1, 0.0).eye, current.eye);
  EXPECT_EQ(stream::extrapolateCamera(current, current, 0.1, 0.05).eye, current.eye);
}

TEST(ClientPose, StereoCarriesThePredictedCamerasEyes) {
  render::Camera current, predicted;
  current.eye = {0, 0, 5};
  current.target = {0, 0, 0};
  predicted.eye = {0, 0, 4};
  predicted.target = {0, 0, -1};
  stream::Pose mono = stream::clientPose(7, current, predicted, 64, 32, std::nullopt);
  EXPECT_EQ(mono.sequence, 7u);
  EXPECT_EQ(mono.camera.eye, current.eye);
  EXPECT_EQ(mono.predicted.eye, predicted.eye);
  EXPECT_EQ(mono.viewportWidth, 64u);
  EXPECT_EQ(mono.viewportHeight, 32u);
  stream::Pose stereo = stream::clientPose(8, current, predicted, 64, 32, 0.2f);
  auto eyes = stream::clientEyes(predicted, 0.2f);
  EXPECT_EQ(stereo.camera.eye, eyes[0].eye);
  EXPECT_EQ(stereo.predicted.eye, eyes[1].eye);
  EXPECT_NEAR(glm::length(stereo.predicted.eye - stereo.camera.eye), 0.2f, 1e-5f);
  EXPECT_NEAR(stereo.camera.eye.x, -0.1f, 1e-5f); // looking along -z, right is +x: left eye at -x
}

} // namespace

class StreamStereo : public test::GpuTest {};

namespace {

TEST_F(StreamStereo, EachHalfEqualsTheMonoStreamOfItsEye) {
  test::StreamTestServer server("gen:city:2", stream::AtlasCodec::ZstdTiles, test::kStreamToken);
  ASSERT_TRUE(server.server);
  stream::StreamClientOptions options;
  options.url = server.url();
  options.token = test::kStreamToken;
  options.width = kStereoWidth;
  options.height = kStereoHeight;
  options.capabilities = stream::kCapabilityZstdTiles;
  options.timeout = std::chrono::milliseconds(60000);

  // The centre cameras: orbit:2 around the bounds the server's Welcome gives.
  Bounds bounds;
  {
    stream::TransportClient probe;
    auto welcome = probe.connect(options.url, stream::transportConfig(options));
    ASSERT_TRUE(welcome) << welcome.error().message;
    bounds.add(welcome->sceneMin);
    bounds.add(welcome->sceneMax);
  }
  std::vector<render::Camera> centres = render::orbitPath(bounds, float(kStereoWidth) / kStereoHeight, 2);
  std::vector<render::Camera> lefts, rights;
  for (const render::Camera& c : centres) {
    auto eyes = stream::clientEyes(c, kIpd);
    lefts.push_back(eyes[0]);
    rights.push_back(eyes[1]);
  }
  std::filesystem::path dir = std::filesystem::temp_directory_path() / fmt::format("stereo_test_{}", getpid());
  std::filesystem::create_directories(dir);
  ASSERT_TRUE(render::writeCameraPath(dir / "centre.json", centres));
  ASSERT_TRUE(render::writeCameraPath(dir / "left.json", lefts));
  ASSERT_TRUE(render::writeCameraPath(dir / "right.json", rights));

  std::vector<ImageRGBA8> left = streamPath(options, (dir / "left.json").string());
  std::vector<ImageRGBA8> right = streamPath(options, (dir / "right.json").string());
  stream::StreamClientOptions stereo = options;
  stereo.stereoIpd = kIpd;
  std::vector<ImageRGBA8> pairs = streamPath(stereo, (dir / "centre.json").string());
  std::filesystem::remove_all(dir);
  ASSERT_EQ(left.size(), 2u);
  ASSERT_EQ(right.size(), 2u);
  ASSERT_EQ(pairs.size(), 2u);
  for (size_t i = 0; i < pairs.size(); ++i) {
    ASSERT_EQ(pairs[i].width, 2 * kStereoWidth);
    ASSERT_EQ(pairs[i].height, kStereoHeight);
    ImageRGBA8 l = half(pairs[i], 0, kStereoWidth), r = half(pairs[i], kStereoWidth, kStereoWidth);
    double pl = psnr(l, left[i]), pr = psnr(r, right[i]), between = psnr(l, r);
    std::printf("camera %zu: left %.2f dB, right %.2f dB, left vs right %.2f dB\n", i, pl, pr, between);
    EXPECT_GE(pl, 40.0) << "camera " << i;
    EXPECT_GE(pr, 40.0) << "camera " << i;
    EXPECT_LT(between, 30.0) << "camera " << i << ": the eyes should see the scene from different places";
  }
}

} // namespace
} // namespace mirage
