// Atlas codecs: the zstd tile-delta codec is bit-exact, sends only changed tiles and rejects damaged
// payloads; the H.264 codec keeps a synthetic atlas above 35 dB near its bitrate target, takes YUV
// planes as it takes RGBA, cuts frames into one slice per thread without holding any back, and
// survives garbage.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mirage/core/image_metrics.h"
#include "mirage/stream/tile_codec.h"
#include "mirage/stream/video.h"

namespace mirage::stream {
namespace {

std::vector<uint8_t> randomImage(uint32_t width, uint32_t height, std::mt19937& rng) {
  std::vector<uint8_t> image(size_t(width) * height * 4);
  for (uint8_t& byte : image) byte = uint8_t(rng());
  return image;
}

void paint(std::vector<uint8_t>& image, uint32_t width, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h,
           uint8_t value) {
  for (uint32_t y = y0; y < y0 + h; ++y) {
    for (uint32_t x = x0; x < x0 + w; ++x) {
      for (uint32_t c = 0; c < 4; ++c) image[(size_t(y) * width + x) * 4 + c] = uint8_t(value + c);
    }
  }
}

uint32_t tileCountOf(const std::vector<uint8_t>& payload) {
  return uint32_t(payload[20]) | uint32_t(payload[21]) << 8 | uint32_t(payload[22]) << 16 | uint32_t(payload[23]) << 24;
}

TEST(TileCodec, SequenceRoundTripsBitExact) {
  constexpr uint32_t kWidth = 100, kHeight = 70; // edge tiles clipped on both axes
  std::mt19937 rng(5);
  std::vector<uint8_t> image = randomImage(kWidth, kHeight, rng);
  TileDeltaEncoder encoder(kWidth, kHeight);
  TileDeltaDecoder decoder;
  for (uint32_t frame = 0; frame < 8; ++frame) {
    if (frame > 0) paint(image, kWidth, (frame * 13) % 90, (frame * 7) % 60, 10, 10, uint8_t(frame * 31));
    auto payload = encoder.encode(image);
    ASSERT_TRUE(payload.ok()) << payload.error().message;
    Status status = decoder.decode(*payload);
    ASSERT_TRUE(status.ok()) << status.error().message;
    ASSERT_EQ(decoder.width(), kWidth);
    ASSERT_EQ(decoder.height(), kHeight);
    EXPECT_EQ(decoder.image(), image) << "frame " << frame;
    EXPECT_EQ(decoder.frame(), frame);
    if (frame > 0) { // a 10 x 10 square touches at most 4 tiles
      EXPECT_LE(tileCountOf(*payload), 4u);
    }
  }
}

TEST(TileCodec, UnchangedFrameCostsHeaderOnly) {
  std::mt19937 rng(6);
  std::vector<uint8_t> image = randomImage(128, 96, rng);
  TileDeltaEncoder encoder(128, 96);
  TileDeltaDecoder decoder;
  auto key = encoder.encode(image);
  ASSERT_TRUE(key.ok());
  EXPECT_EQ(tileCountOf(*key), 4u * 3u);
  ASSERT_TRUE(decoder.decode(*key).ok());
  auto same = encoder.encode(image);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->size(), kTileDeltaHeaderBytes);
  ASSERT_TRUE(decoder.decode(*same).ok());
  image[(50 * 128 + 70) * 4] ^= 1; // one pixel: one tile
  auto one = encoder.encode(image);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(tileCountOf(*one), 1u);
  ASSERT_TRUE(decoder.decode(*one).ok());
  EXPECT_EQ(decoder.image(), image);
}

TEST(TileCodec, DamagedPayloadsRejectedAndImageKept) {
  std::mt19937 rng(7);
  std::vector<uint8_t> image = randomImage(64, 64, rng);
  for (size_t i = 0; i < image.size(); i += 3) image[i] = 0; // compressible, so the body is short
  TileDeltaEncoder encoder(64, 64);
  TileDeltaDecoder decoder;
  auto key = encoder.encode(image);
  ASSERT_TRUE(key.ok());
  ASSERT_TRUE(decoder.decode(*key).ok());
  std::vector<uint8_t> changed = image;
  paint(changed, 64, 0, 0, 8, 8, 200);
  auto delta = encoder.encode(changed);
  ASSERT_TRUE(delta.ok());

  // Every truncation and every single-byte corruption of the delta fails; the image stays.
  for (size_t length = 0; length < delta->size(); ++length) {
    std::vector<uint8_t> cut(delta->begin(), delta->begin() + std::ptrdiff_t(length));
    EXPECT_FALSE(decoder.decode(cut).ok()) << "length " << length;
  }
  for (size_t at = 0; at < delta->size(); ++at) {
    if (at >= 12 && at < 16) continue; // the frame number itself is not checked
    std::vector<uint8_t> bad = *delta;
    bad[at] ^= 0x5a;
    Status status = decoder.decode(bad);
    EXPECT_FALSE(status.ok()) << "byte " << at;
    if (!status.ok()) {
      EXPECT_FALSE(status.error().message.empty());
    }
  }
  EXPECT_EQ(decoder.image(), image);
  ASSERT_TRUE(decoder.decode(*delta).ok());
  EXPECT_EQ(decoder.image(), changed);
}

TEST(TileCodec, MissingBaseFrameNeedsKeyframe) {
  std::mt19937 rng(8);
  std::vector<uint8_t> image = randomImage(64, 32, rng);
  TileDeltaEncoder encoder(64, 32);
  auto key = encoder.encode(image);
  paint(image, 64, 40, 0, 4, 4, 9);
  auto lost = encoder.encode(image);
  paint(image, 64, 0, 20, 4, 4, 19);
  auto next = encoder.encode(image);
  ASSERT_TRUE(key.ok() && lost.ok() && next.ok());

  TileDeltaDecoder fresh;
  EXPECT_FALSE(fresh.decode(*lost).ok()); // a delta before any keyframe
  ASSERT_TRUE(fresh.decode(*key).ok());
  Status skipped = fresh.decode(*next); // frame 1 was lost
  ASSERT_FALSE(skipped.ok());
  EXPECT_NE(skipped.error().message.find("keyframe"), std::string::npos) << skipped.error().message;
  encoder.requestKeyframe();
  auto recovery = encoder.encode(image);
  ASSERT_TRUE(recovery.ok());
  ASSERT_TRUE(fresh.decode(*recovery).ok());
  EXPECT_EQ(fresh.image(), image);
  EXPECT_FALSE(encoder.encode(std::vector<uint8_t>(10)).ok()); // wrong image size
}

// A synthetic atlas: blocks of smooth gradients with hard edges between them, drifting each frame
// as reshaded blocks do. Hard edges sit on even texels, as block borders do (blocks are >= 2 x 2
// and aligned to their size): 4:2:0 keeps one chroma sample per 2 x 2 texels.
std::vector<uint8_t> syntheticAtlas(uint32_t size, uint32_t frame) {
  std::vector<uint8_t> image(size_t(size) * size * 4);
  for (uint32_t y = 0; y < size; ++y) {
    for (uint32_t x = 0; x < size; ++x) {
      uint32_t block = (x / 32) * 7 + (y / 32) * 13;
      float u = float(x % 32) / 31.0f, v = float(y % 32) / 31.0f;
      float phase = float(frame) * 0.15f + float(block);
      uint8_t* p = &image[(size_t(y) * size + x) * 4];
      p[0] = uint8_t(40 + 170 * (0.5f + 0.5f * std::sin(phase + 2.0f * u)));
      p[1] = uint8_t(30 + 180 * (0.5f + 0.5f * std::cos(phase * 0.7f + 1.5f * v)));
      p[2] = uint8_t((block * 37 + frame * 3) % 256);
      p[3] = 255;
      if ((x + 2 * frame) % 64 < 2 || (y % 48) < 2) p[0] = p[1] = p[2] = 250; // edges
    }
  }
  return image;
}

ImageRGBA8 asImage(const std::vector<uint8_t>& rgba, uint32_t width, uint32_t height) {
  return ImageRGBA8{width, height, rgba};
}

TEST(VideoCodec, SyntheticAtlasRoundTripAboveThirtyFiveDb) {
  constexpr uint32_t kSize = 256;
  VideoConfig config{.width = kSize, .height = kSize, .fps = 30, .bitrateKbps = 4000};
  auto encoder = VideoEncoder::create(config);
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  auto decoder = VideoDecoder::create();
  ASSERT_TRUE(decoder.ok()) << decoder.error().message;
  size_t bytes = 0;
  constexpr uint32_t kFrames = 10;
  for (uint32_t frame = 0; frame < kFrames; ++frame) {
    std::vector<uint8_t> source = syntheticAtlas(kSize, frame);
    auto packet = encoder->encode(source);
    ASSERT_TRUE(packet.ok()) << packet.error().message;
    ASSERT_FALSE(packet->data.empty()) << "zero latency: one packet per frame, frame " << frame;
    if (frame == 0) {
      EXPECT_TRUE(packet->keyframe);
    }
    bytes += packet->data.size();
    auto got = decoder->decode(packet->data);
    ASSERT_TRUE(got.ok()) << got.error().message;
    ASSERT_TRUE(*got) << "no frame out for frame " << frame;
    ASSERT_EQ(decoder->width(), kSize);
    ASSERT_EQ(decoder->height(), kSize);
    double quality = psnr(asImage(source, kSize, kSize), asImage(decoder->image(), kSize, kSize));
    std::printf("frame %u: %zu bytes, %.2f dB\n", frame, packet->data.size(), quality);
    EXPECT_GE(quality, 35.0) << "frame " << frame;
    EXPECT_EQ(decoder->image()[3], 255); // alpha is not carried
  }
  // The rate control's target, to an order of magnitude (the first frame is an IDR).
  double target = double(config.bitrateKbps) * 1000.0 / 8.0 / config.fps;
  double mean = double(bytes) / kFrames;
  EXPECT_GT(mean, target / 10.0);
  EXPECT_LT(mean, target * 10.0);
}

// setBitrate takes effect from the next frame without a keyframe: noise, which any rate fills,
// drops to about the new target's frame size.
TEST(VideoCodec, SetBitrateTakesEffectWithoutAKeyframe) {
  constexpr uint32_t kSize = 256;
  VideoConfig config{.width = kSize, .height = kSize, .fps = 30, .bitrateKbps = 8000};
  auto encoder = VideoEncoder::create(config);
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  auto decoder = VideoDecoder::create();
  ASSERT_TRUE(decoder.ok()) << decoder.error().message;
  std::mt19937 rng(5);
  auto meanBytes = [&](uint32_t frames, bool expectKeyframe) {
    double bytes = 0;
    for (uint32_t i = 0; i < frames; ++i) {
      auto packet = encoder->encode(randomImage(kSize, kSize, rng));
      EXPECT_TRUE(packet.ok()) << packet.error().message;
      if (!packet) return 0.0;
      if (!expectKeyframe || i > 0) {
        EXPECT_FALSE(packet->keyframe) << "frame " << i;
      }
      auto got = decoder->decode(packet->data);
      EXPECT_TRUE(got.ok() && *got) << "frame " << i;
      if (i >= frames / 2) bytes += double(packet->data.size()) / (frames - frames / 2);
    }
    return bytes;
  };
  const double high = meanBytes(12, true);
  encoder->setBitrate(1000);
  EXPECT_EQ(encoder->config().bitrateKbps, 1000u);
  const double low = meanBytes(12, false);
  std::printf("noise at 8000 kbit/s: %.0f bytes a frame, at 1000: %.0f (targets %.0f, %.0f)\n", high, low,
              8000 * 1000 / 8.0 / 30, 1000 * 1000 / 8.0 / 30);
  EXPECT_LT(low, high / 4.0);
  EXPECT_LT(low, 1000 * 1000 / 8.0 / 30 * 1.5);
}

TEST(VideoCodec, ForcedKeyframeStartsAJoiningDecoder) {
  auto encoder = VideoEncoder::create({.width = 64, .height = 64, .fps = 30, .bitrateKbps = 1000});
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  VideoPacket forced;
  for (uint32_t frame = 0; frame < 6; ++frame) {
    auto packet = encoder->encode(syntheticAtlas(64, frame), frame == 4);
    ASSERT_TRUE(packet.ok());
    if (frame > 0 && frame != 4) {
      EXPECT_FALSE(packet->keyframe) << "frame " << frame;
    }
    if (frame == 4) forced = *packet;
  }
  EXPECT_TRUE(forced.keyframe);
  auto joining = VideoDecoder::create();
  ASSERT_TRUE(joining.ok());
  auto got = joining->decode(forced.data);
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_TRUE(*got);
  EXPECT_GE(psnr(asImage(syntheticAtlas(64, 4), 64, 64), asImage(joining->image(), 64, 64)), 30.0);
}

TEST(VideoCodec, IntraRefreshStreamDecodes) {
  auto encoder =
      VideoEncoder::create({.width = 128, .height = 128, .fps = 30, .bitrateKbps = 3000, .intraRefresh = true});
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  auto decoder = VideoDecoder::create();
  ASSERT_TRUE(decoder.ok());
  for (uint32_t frame = 0; frame < 8; ++frame) {
    std::vector<uint8_t> source = syntheticAtlas(128, frame);
    auto packet = encoder->encode(source);
    ASSERT_TRUE(packet.ok()) << packet.error().message;
    auto got = decoder->decode(packet->data);
    ASSERT_TRUE(got.ok()) << got.error().message;
    ASSERT_TRUE(*got) << "frame " << frame;
    EXPECT_GE(psnr(asImage(source, 128, 128), asImage(decoder->image(), 128, 128)), 35.0) << "frame " << frame;
  }
}

TEST(VideoCodec, I420EntryEncodesAsTheRgbaEntry) {
  // The server hands the encoder YUV planes converted on the GPU; given swscale's planes, the
  // stream is the one the RGBA entry makes. One thread: with slice threads x264's rate control
  // depends on their timing, and two runs differ (measured: 2 threads, 512 x 1024).
  VideoConfig config{.width = 128, .height = 64, .fps = 30, .bitrateKbps = 2000, .threads = 1};
  auto fromRgba = VideoEncoder::create(config);
  auto fromI420 = VideoEncoder::create(config);
  ASSERT_TRUE(fromRgba.ok() && fromI420.ok());
  for (uint32_t frame = 0; frame < 4; ++frame) {
    std::vector<uint8_t> rgba = syntheticAtlas(128, frame);
    rgba.resize(size_t(128) * 64 * 4); // the top half: a 128 x 64 image
    auto planes = rgbaToI420(rgba, 128, 64);
    ASSERT_TRUE(planes.ok()) << planes.error().message;
    ASSERT_EQ(planes->size(), size_t(128) * 64 * 3 / 2);
    auto a = fromRgba->encode(rgba, frame == 2);
    auto b = fromI420->encodeI420(*planes, frame == 2);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->data, b->data) << "frame " << frame;
    EXPECT_EQ(a->keyframe, b->keyframe);
  }
  EXPECT_FALSE(fromI420->encodeI420(std::vector<uint8_t>(128 * 64 * 4)).ok()) << "RGBA bytes given as I420";
  EXPECT_FALSE(rgbaToI420(std::vector<uint8_t>(15), 2, 2).ok()) << "a byte short";
  EXPECT_FALSE(rgbaToI420(std::vector<uint8_t>(3 * 2 * 4), 3, 2).ok()) << "odd width";
}

// The slices of an Annex B access unit (NAL types 1 and 5).
uint32_t sliceCount(const std::vector<uint8_t>& annexB) {
  uint32_t slices = 0;
  for (size_t i = 0; i + 3 < annexB.size(); ++i)
    if (annexB[i] == 0 && annexB[i + 1] == 0 && annexB[i + 2] == 1) {
      uint8_t type = annexB[i + 3] & 0x1f;
      slices += type == 1 || type == 5;
      i += 2;
    }
  return slices;
}

TEST(VideoCodec, ThreadsAreSlicesNotFrameDelay) {
  // zerolatency's slice threads: every frame is one slice per thread and comes out at once
  // (frame threads would hold threads - 1 frames back). 256 rows: 16 macroblock rows, x264's
  // limit of 4 rows per slice thread allows 4.
  auto encoder = VideoEncoder::create({.width = 256, .height = 256, .fps = 30, .bitrateKbps = 4000, .threads = 4});
  ASSERT_TRUE(encoder.ok()) << encoder.error().message;
  for (uint32_t frame = 0; frame < 3; ++frame) {
    auto packet = encoder->encode(syntheticAtlas(256, frame));
    ASSERT_TRUE(packet.ok()) << packet.error().message;
    EXPECT_EQ(sliceCount(packet->data), 4u) << "frame " << frame;
  }
  auto single = VideoEncoder::create({.width = 256, .height = 256, .threads = 1});
  ASSERT_TRUE(single.ok());
  auto packet = single->encode(syntheticAtlas(256, 0));
  ASSERT_TRUE(packet.ok());
  EXPECT_EQ(sliceCount(packet->data), 1u);
}

TEST(VideoCodec, GarbageAndBadConfigsRejected) {
  EXPECT_FALSE(VideoEncoder::create({.width = 63, .height = 64}).ok());
  EXPECT_FALSE(VideoEncoder::create({.width = 0, .height = 64}).ok());
  EXPECT_FALSE(VideoEncoder::create({.width = 64, .height = 64, .bitrateKbps = 0}).ok());
  auto encoder = VideoEncoder::create({.width = 64, .height = 64});
  ASSERT_TRUE(encoder.ok());
  EXPECT_FALSE(encoder->encode(std::vector<uint8_t>(17)).ok());

  auto decoder = VideoDecoder::create();
  ASSERT_TRUE(decoder.ok());
  std::mt19937 rng(9);
  for (uint32_t attempt = 0; attempt < 20; ++attempt) {
    std::vector<uint8_t> garbage(1 + rng() % 4000);
    for (uint8_t& byte : garbage) byte = uint8_t(rng());
    if (attempt % 2) garbage.insert(garbage.begin(), {0, 0, 0, 1, 0x67}); // a start code and an SPS type
    auto got = decoder->decode(garbage);
    EXPECT_TRUE(!got.ok() || !*got) << "garbage decoded as a frame";
  }
  // A truncated real keyframe: an error or no frame, never a crash.
  auto key = encoder->encode(syntheticAtlas(64, 0));
  ASSERT_TRUE(key.ok());
  auto fresh = VideoDecoder::create();
  ASSERT_TRUE(fresh.ok());
  std::vector<uint8_t> half(key->data.begin(), key->data.begin() + std::ptrdiff_t(key->data.size() / 2));
  auto got = fresh->decode(half);
  if (got.ok() && *got) {
    EXPECT_EQ(fresh->image().size(), 64u * 64u * 4u);
  }
}

} // namespace
} // namespace mirage::stream
