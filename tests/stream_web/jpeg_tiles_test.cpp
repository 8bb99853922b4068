#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <random>

#include "mirage/core/image_metrics.h"
#include "mirage/stream/jpeg_tiles.h"

using namespace mirage;
using namespace mirage::stream;

namespace {

// An atlas-like image: smooth shading inside 16x16 blocks, hard edges between blocks, a size that is
// not a multiple of the tile side (edge tiles are clipped).
ImageRGBA8 atlasImage(uint32_t w, uint32_t h, float phase) {
  ImageRGBA8 img;
  img.width = w;
  img.height = h;
  img.pixels.assign(size_t(w) * h * 4, 255);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      uint32_t block = (x / 16) * 7 + (y / 16) * 13;
      uint8_t* p = img.at(x, y);
      p[0] = uint8_t(60 + (block * 37) % 120 + 30 * std::sin(0.2f * float(x) + phase));
      p[1] = uint8_t(60 + (block * 53) % 120 + 30 * std::cos(0.15f * float(y)));
      p[2] = uint8_t(60 + (block * 91) % 120 + 20 * std::sin(0.1f * float(x + y)));
    }
  return img;
}

ImageRGBA8 decoded(const JpegTileDecoder& decoder, uint32_t w, uint32_t h) {
  ImageRGBA8 img;
  img.width = w;
  img.height = h;
  img.pixels = decoder.rgba();
  return img;
}

TEST(JpegTiles, KeyframeDecodesAbove35dB) {
  const uint32_t w = 200, h = 136;
  ImageRGBA8 source = atlasImage(w, h, 0.0f);
  JpegTileEncoder encoder(w, h, {.quality = 90});
  auto payload = encoder.encode(source.pixels);
  ASSERT_TRUE(payload) << payload.error().message;
  Result<JpegTilesHeader> header = readJpegTilesHeader(*payload, "test");
  ASSERT_TRUE(header) << header.error().message;
  EXPECT_TRUE(header->keyframe());
  JpegTileDecoder decoder(w, h);
  Status status = decoder.decode(*payload, "test");
  ASSERT_TRUE(status) << status.error().message;
  double quality = psnr(source, decoded(decoder, w, h));
  std::printf("200x136 keyframe at quality 90: %zu bytes, %.1f dB\n", payload->size(), quality);
  EXPECT_GE(quality, 35.0);
  EXPECT_LT(payload->size(), size_t(w) * h * 3 / 2); // compressed well below raw RGB
}

TEST(JpegTiles, UnchangedFrameIsTheHeaderAlone) {
  const uint32_t w = 96, h = 64;
  ImageRGBA8 source = atlasImage(w, h, 0.0f);
  JpegTileEncoder encoder(w, h);
  ASSERT_TRUE(encoder.encode(source.pixels));
  // Alpha is not carried: changing it alone changes nothing.
  for (size_t i = 3; i < source.pixels.size(); i += 4) source.pixels[i] = 7;
  auto again = encoder.encode(source.pixels);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->size(), kJpegTilesHeaderBytes);
  Result<JpegTilesHeader> header = readJpegTilesHeader(*again, "test");
  ASSERT_TRUE(header);
  EXPECT_FALSE(header->keyframe());
  EXPECT_EQ(header->stripCount, 0u);
}

TEST(JpegTiles, DeltaCarriesOnlyChangedTilesAndTracksTheSource) {
  const uint32_t w = 160, h = 96; // 5 x 3 tiles
  ImageRGBA8 first = atlasImage(w, h, 0.0f);
  ImageRGBA8 second = first;
  // Change one texel in tile (1, 0) and a block in tiles (3, 2) and (4, 2).
  second.at(40, 5)[0] ^= 0x40;
  for (uint32_t y = 70; y < 90; ++y)
    for (uint32_t x = 100; x < 150; ++x) second.at(x, y)[1] = 250;
  JpegTileEncoder encoder(w, h, {.quality = 90, .maxStripTiles = 1});
  JpegTileDecoder decoder(w, h);
  auto key = encoder.encode(first.pixels);
  ASSERT_TRUE(key);
  ASSERT_TRUE(decoder.decode(*key, "key"));
  auto delta = encoder.encode(second.pixels);
  ASSERT_TRUE(delta);
  Result<JpegTilesHeader> header = readJpegTilesHeader(*delta, "delta");
  ASSERT_TRUE(header);
  EXPECT_EQ(header->stripCount, 3u); // one strip per tile with maxStripTiles = 1
  EXPECT_EQ(header->baseFrame, 0u);
  EXPECT_EQ(header->frame, 1u);
  Status status = decoder.decode(*delta, "delta");
  ASSERT_TRUE(status) << status.error().message;
  EXPECT_GE(psnr(second, decoded(decoder, w, h)), 35.0);
  EXPECT_NEAR(double(decoder.rgba()[(size_t(80) * w + 120) * 4 + 1]), 250.0, 8.0);

  // The same change packed: the three tiles (not adjacent) share one strip.
  JpegTileEncoder packed(w, h);
  ASSERT_TRUE(packed.encode(first.pixels));
  auto packedDelta = packed.encode(second.pixels);
  ASSERT_TRUE(packedDelta);
  Result<JpegTilesHeader> packedHeader = readJpegTilesHeader(*packedDelta, "packed");
  ASSERT_TRUE(packedHeader);
  EXPECT_EQ(packedHeader->stripCount, 1u);
  EXPECT_LT(packedDelta->size(), delta->size());
  JpegTileDecoder packedDecoder(w, h);
  ASSERT_TRUE(packedDecoder.decode(*key, "key"));
  Status packedStatus = packedDecoder.decode(*packedDelta, "packed");
  ASSERT_TRUE(packedStatus) << packedStatus.error().message;
  EXPECT_GE(psnr(second, decoded(packedDecoder, w, h)), 35.0);
}

// Flat, saturated tiles of unrelated colours, every other one changed: packed strips put unrelated
// tiles side by side, and no texel (tile edges included) may take colour from its strip neighbour.
double packedEdgeError(bool subsampleChroma) {
  const uint32_t w = 256, h = 64;
  auto paint = [&](uint32_t salt) {
    ImageRGBA8 img;
    img.width = w;
    img.height = h;
    img.pixels.assign(size_t(w) * h * 4, 255);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        uint32_t tile = (y / 32) * 8 + x / 32;
        uint32_t hue = (tile % 2 == 0 ? tile * salt : tile) % 6; // odd tiles never change
        uint8_t* p = img.at(x, y);
        p[0] = (hue == 0 || hue == 1 || hue == 5) ? 230 : 20;
        p[1] = (hue >= 1 && hue <= 3) ? 230 : 20;
        p[2] = (hue >= 3 && hue <= 5) ? 230 : 20;
      }
    return img;
  };
  JpegTileEncoder encoder(w, h, {.quality = 90, .subsampleChroma = subsampleChroma});
  JpegTileDecoder decoder(w, h);
  ImageRGBA8 first = paint(1), second = paint(5);
  auto key = encoder.encode(first.pixels);
  auto delta = encoder.encode(second.pixels);
  EXPECT_TRUE(key && delta && decoder.decode(*key, "key") && decoder.decode(*delta, "delta"));
  double worst = 0.0;
  for (size_t i = 0; i < second.pixels.size(); ++i)
    if (i % 4 != 3) worst = std::max(worst, std::abs(double(second.pixels[i]) - double(decoder.rgba()[i])));
  return worst;
}

TEST(JpegTiles, PackedTilesKeepTheirOwnColours) {
  double whole = packedEdgeError(false), halved = packedEdgeError(true);
  std::printf("worst texel error, unrelated tiles packed side by side: %.0f (chroma whole), %.0f (4:2:0)\n", whole,
              halved);
  EXPECT_LE(whole, 16.0);
  EXPECT_GT(halved, whole); // what whole chroma is for
}

TEST(JpegTiles, StripsCostLessThanSingleTiles) {
  // Per-JPEG headers (quantization and Huffman tables, ~620 bytes) dominate small tiles; strips of
  // 16 tiles amortize them. The measured sizes go to docs/stream.md, "The browser client".
  const uint32_t w = 512, h = 256;
  ImageRGBA8 source = atlasImage(w, h, 0.3f);
  JpegTileEncoder single(w, h, {.quality = 90, .maxStripTiles = 1});
  JpegTileEncoder strips(w, h, {.quality = 90, .maxStripTiles = 16});
  auto a = single.encode(source.pixels);
  auto b = strips.encode(source.pixels);
  ASSERT_TRUE(a && b);
  std::printf("512x256 keyframe at quality 90: %zu bytes as single tiles, %zu bytes as 16-tile strips\n", a->size(),
              b->size());
  EXPECT_LT(b->size(), a->size());
  JpegTileDecoder decoder(w, h);
  ASSERT_TRUE(decoder.decode(*b, "strips"));
  EXPECT_GE(psnr(source, decoded(decoder, w, h)), 35.0);
}

TEST(JpegTiles, CorruptPayloadsAreRejectedAndLeaveTheImage) {
  const uint32_t w = 96, h = 64;
  ImageRGBA8 source = atlasImage(w, h, 0.0f);
  JpegTileEncoder encoder(w, h);
  auto payload = encoder.encode(source.pixels);
  ASSERT_TRUE(payload);
  JpegTileDecoder decoder(w, h);
  ASSERT_TRUE(decoder.decode(*payload, "good"));
  const std::vector<uint8_t> before = decoder.rgba();

  auto expectRejected = [&](std::vector<uint8_t> bytes, const char* what) {
    Status status = decoder.decode(bytes, "peer");
    ASSERT_FALSE(status) << what;
    EXPECT_EQ(status.error().message.rfind("peer: ", 0), 0u) << status.error().message;
    EXPECT_EQ(status.error().message.find('\n'), std::string::npos);
    EXPECT_EQ(decoder.rgba(), before) << what;
  };
  std::vector<uint8_t> bad = *payload;
  bad[0] = 'X';
  expectRejected(bad, "magic");
  expectRejected(std::vector<uint8_t>(payload->begin(), payload->begin() + 30), "truncated");
  bad = *payload;
  bad[4] = 95; // width
  expectRejected(bad, "size");
  bad = *payload;
  bad[20] = 200; // strip count
  expectRejected(bad, "strip count");
  bad = *payload;
  bad[24] = 9; // tiles in the strip: more than the atlas has
  expectRejected(bad, "tile count");
  bad = *payload;
  bad[32] = 99; // first tile index
  expectRejected(bad, "tile index");
  bad = *payload;
  bad[36] = 0; // second tile index not after the first
  expectRejected(bad, "tile order");
  bad = *payload;
  bad.push_back(0);
  expectRejected(bad, "trailing");
  // Random bytes inside every JPEG: either rejected or decoded, never a crash or a hang.
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    bad = *payload;
    for (int k = 0; k < 8; ++k) bad[kJpegTilesHeaderBytes + kJpegStripHeaderBytes + rng() % 400] = uint8_t(rng());
    (void)decoder.decode(bad, "fuzz");
  }
  // A delta on a frame the decoder never saw.
  JpegTileEncoder other(w, h);
  ASSERT_TRUE(other.encode(source.pixels));
  ASSERT_TRUE(other.encode(source.pixels));
  auto lateDelta = other.encode(atlasImage(w, h, 1.0f).pixels);
  ASSERT_TRUE(lateDelta);
  JpegTileDecoder fresh(w, h);
  Status status = fresh.decode(*lateDelta, "peer");
  ASSERT_FALSE(status);
  EXPECT_NE(status.error().message.find("delta on frame 1"), std::string::npos) << status.error().message;
}

// Payloads for tests/stream_web/browser_test.py, which decodes them in Chromium (web/test.html?payload)
// and compares the browser's atlas with this decoder's: the C++ encoder and the JavaScript decoder must
// agree on the byte layout (JPEG decoders differ only in rounding). Runs only when that script names the output folder.
TEST(JpegTiles, WritesBrowserFixture) {
  const char* dir = std::getenv("MIRAGE_JPEG_TILES_FIXTURE");
  if (!dir) GTEST_SKIP() << "MIRAGE_JPEG_TILES_FIXTURE not set (tests/stream_web/browser_test.py sets it)";
  const uint32_t w = 200, h = 136;
  ImageRGBA8 first = atlasImage(w, h, 0.0f);
  ImageRGBA8 second = first;
  for (uint32_t y = 40; y < 90; ++y)
    for (uint32_t x = 70; x < 180; ++x) second.at(x, y)[0] = uint8_t(255 - second.at(x, y)[0]);
  JpegTileEncoder encoder(w, h);
  auto key = encoder.encode(first.pixels);
  auto delta = encoder.encode(second.pixels);
  ASSERT_TRUE(key && delta);
  auto write = [&](const std::string& name, const std::vector<uint8_t>& bytes) {
    std::ofstream out(std::string(dir) + "/" + name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    ASSERT_TRUE(out.good()) << name;
  };
  JpegTileDecoder decoder(w, h);
  ASSERT_TRUE(decoder.decode(*key, "key") && decoder.decode(*delta, "delta"));
  write("key.mjt", *key);
  write("delta.mjt", *delta);
  write("expected.rgba", decoder.rgba()); // what the reference decoder makes of them
}

TEST(JpegTiles, WrongImageSizeIsAnError) {
  JpegTileEncoder encoder(64, 64);
  std::vector<uint8_t> small(10);
  auto result = encoder.encode(small);
  ASSERT_FALSE(result);
  EXPECT_NE(result.error().message.find("64x64"), std::string::npos);
}

} // namespace
