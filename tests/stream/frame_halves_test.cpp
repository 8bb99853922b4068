// A client frame in two halves (ClientStream::prepareFrame on the GPU, finishFrame on any thread),
// as the server overlaps one client's encode with the next client's GPU stages: a frame finished
// after another client was prepared (the scene's GPU atlas shaded over) is byte for byte the frame
// made in one go; frame workers run every job, also those queued when they stop.
#include <atomic>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/stream/session.h"
#include "stream/frame_workers.h"

namespace mirage {
namespace {

// The Frame's bytes without its server time (the one field that differs run to run).
std::vector<uint8_t> frameBytes(stream::Frame frame) {
  frame.serverTimeUs = 0;
  return stream::encodeMessage(frame);
}

stream::Pose poseOf(const render::Camera& camera, uint32_t sequence) {
  stream::Pose pose;
  pose.sequence = sequence;
  pose.camera = pose.predicted = stream::toProtocolCamera(camera);
  pose.viewportWidth = 160;
  pose.viewportHeight = 90;
  return pose;
}

class StreamFrameHalves : public test::GpuTest {
protected:
  // Two clients at two cameras, two frames each: in one go each, and with each client's finish
  // after the other's prepare; the same frames.
  void expectInterleavedEqualsSerial(stream::AtlasCodec codec) {
    stream::StreamSceneOptions options;
    options.input = "gen:city:2";
    options.atlasSize = 512;
    auto scene = stream::openStreamScene(context(), options);
    ASSERT_TRUE(scene) << scene.error().message;
    ASSERT_TRUE((*scene)->translucent) << "the city's glass: H.264 and JPEG stack the alpha";
    auto cameras = render::orbitPath((*scene)->bounds, 16.0f / 9.0f, 4);
    stream::ClientStreamConfig config;
    config.codec = codec;
    config.encoderThreads = 1; // with slice threads x264's rate control depends on their timing
    auto make = [&] {
      auto c = stream::ClientStream::create(**scene, config);
      EXPECT_TRUE(c) << c.error().message;
      return c ? std::move(*c) : nullptr;
    };
    auto a = make(), b = make(), a2 = make(), b2 = make();
    ASSERT_TRUE(a && b && a2 && b2);
    for (uint32_t f = 0; f < 2; ++f) {
      stream::Pose pa = poseOf(cameras[f], f + 1), pb = poseOf(cameras[2 + f], f + 1);
      auto serialA = a->produceFrame(**scene, pa);
      auto serialB = b->produceFrame(**scene, pb);
      ASSERT_TRUE(serialA && serialB);
      ASSERT_TRUE(a2->prepareFrame(**scene, pa));
      ASSERT_TRUE(b2->prepareFrame(**scene, pb)); // shades the GPU's atlas over a2's
      auto finishedA = a2->finishFrame(**scene);
      auto finishedB = b2->finishFrame(**scene);
      ASSERT_TRUE(finishedA && finishedB);
      EXPECT_FALSE(serialA->atlas.bytes.empty());
      EXPECT_EQ(serialA->atlas.height, 1024u);
      EXPECT_EQ(frameBytes(*finishedA), frameBytes(*serialA)) << "client a, frame " << f;
      EXPECT_EQ(frameBytes(*finishedB), frameBytes(*serialB)) << "client b, frame " << f;
      EXPECT_NE(serialA->atlas.bytes, serialB->atlas.bytes) << "two cameras, two atlases";
    }
    EXPECT_FALSE(a2->finishFrame(**scene)) << "nothing prepared";
  }
};

TEST_F(StreamFrameHalves, H264FinishedAfterAnotherClientsPrepareIsTheSameFrame) {
  expectInterleavedEqualsSerial(stream::AtlasCodec::H264);
}

TEST_F(StreamFrameHalves, JpegFinishedAfterAnotherClientsPrepareIsTheSameFrame) {
  expectInterleavedEqualsSerial(stream::AtlasCodec::JpegTiles);
}

TEST(StreamFrameWorkers, EveryJobRunsAndQueuedJobsFinishOnStop) {
  std::atomic<int> ran{0};
  std::vector<std::future<int>> results;
  {
    stream::FrameWorkers workers(3);
    for (int i = 0; i < 100; ++i) results.push_back(workers.submit([i, &ran] { return ++ran, i * i; }));
  } // stops with jobs still queued: they run first
  EXPECT_EQ(ran.load(), 100);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(results[size_t(i)].get(), i * i);
  EXPECT_EQ(stream::frameWorkerCount(5), 5u);
  EXPECT_GE(stream::frameWorkerCount(0), 2u);
  EXPECT_LE(stream::frameWorkerCount(0), 8u);
}

} // namespace
} // namespace mirage
