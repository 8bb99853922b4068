// The stream server's H.264 encode on its largest common image: a 2048 atlas with stacked alpha,
// 2048 x 4096 (docs/stream.md, "Server time"). Whether x264's slice threads scale on this machine
// (the server's encoder takes YUV planes converted on the GPU): BM_H264EncodeI420/threads, 0 being
// x264's own choice; and what the CPU conversion the GPU replaced costs (BM_RgbaToI420).
//   build/bench/mirage_microbench --benchmark_filter='H264|I420'
// The frames are synthetic: blocks of smooth shading whose edges move a little each frame, the lower
// half constant grey as an alpha mostly is. Real atlases hold more unchanged blocks (cheaper P-frames).
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "mirage/stream/video.h"

using namespace mirage;

namespace {

constexpr uint32_t kWidth = 2048, kHeight = 4096, kFrames = 4;

// I420 frame `frame` of the synthetic stacked atlas.
std::vector<uint8_t> syntheticI420(uint32_t frame) {
  std::vector<uint8_t> image(size_t(kWidth) * kHeight * 3 / 2);
  uint8_t* y = image.data();
  uint8_t* u = y + size_t(kWidth) * kHeight;
  uint8_t* v = u + size_t(kWidth) * kHeight / 4;
  for (uint32_t row = 0; row < kHeight; ++row)
    for (uint32_t x = 0; x < kWidth; ++x) {
      uint32_t block = (x / 32) * 7 + (row / 32) * 13;
      float phase = float(frame) * 0.15f + float(block);
      bool edge = (x + 2 * frame) % 64 < 2;
      y[size_t(row) * kWidth + x] = row >= kHeight / 2 ? 255
                                    : edge
                                        ? 250
                                        : uint8_t(40 + 170 * (0.5f + 0.5f * std::sin(phase + float(x % 32) / 16.0f)));
    }
  for (uint32_t row = 0; row < kHeight / 2; ++row)
    for (uint32_t x = 0; x < kWidth / 2; ++x) {
      uint32_t block = (x / 16) * 7 + (row / 16) * 13;
      bool below = row >= kHeight / 4;
      u[size_t(row) * kWidth / 2 + x] = below ? 128 : uint8_t(block * 37 % 200 + 28);
      v[size_t(row) * kWidth / 2 + x] = below ? 128 : uint8_t(block * 53 % 200 + 28);
    }
  return image;
}

void BM_H264EncodeI420(benchmark::State& state) {
  std::vector<std::vector<uint8_t>> frames;
  for (uint32_t f = 0; f < kFrames; ++f) frames.push_back(syntheticI420(f));
  stream::VideoConfig config{.width = kWidth, .height = kHeight, .fps = 60, .bitrateKbps = 20000};
  config.threads = uint32_t(state.range(0));
  auto encoder = stream::VideoEncoder::create(config);
  if (!encoder) {
    state.SkipWithError(encoder.error().message.c_str());
    return;
  }
  (void)encoder->encodeI420(frames[0], /*forceKeyframe=*/true); // the IDR: not what a client costs each frame
  uint32_t next = 1;
  for (auto _ : state) {
    auto packet = encoder->encodeI420(frames[next++ % kFrames]);
    benchmark::DoNotOptimize(packet.ok());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_H264EncodeI420)
    ->Arg(1)
    ->Arg(2)
    ->Arg(4)
    ->Arg(8)
    ->Arg(16)
    ->Arg(0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_RgbaToI420(benchmark::State& state) {
  std::vector<uint8_t> rgba(size_t(kWidth) * kHeight * 4);
  for (size_t i = 0; i < rgba.size(); ++i) rgba[i] = uint8_t(i * 2654435761u >> 24);
  for (auto _ : state) benchmark::DoNotOptimize(stream::rgbaToI420(rgba, kWidth, kHeight).ok());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RgbaToI420)->Unit(benchmark::kMillisecond)->UseRealTime();

} // namespace
