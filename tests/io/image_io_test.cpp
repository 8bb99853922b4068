#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>

#include "mirage/io/image_io.h"
#include "test_support.h"

using namespace mirage;
namespace fs = std::filesystem;

namespace {

void spit(const fs::path& p, const std::vector<uint8_t>& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

template <class T> T peek(const std::vector<uint8_t>& b, size_t at) {
  T v{};
  std::memcpy(&v, &b[at], sizeof(T));
  return v;
}

ImageF32 floatImage(uint32_t w, uint32_t h) {
  ImageF32 img{w, h, std::vector<float>(size_t(w) * h * 4)};
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = float(i) * 0.25f - 3.0f;
  return img;
}

size_t entries(const fs::path& dir) { return size_t(std::distance(fs::directory_iterator(dir), {})); }

} // namespace

TEST(ImageIo, PngRoundTrip) {
  fs::path dir = test::tempDir("png_round_trip");
  ImageRGBA8 img{7, 5, {}};
  for (uint32_t i = 0; i < 7 * 5 * 4; ++i) img.pixels.push_back(uint8_t(i * 37));
  ASSERT_TRUE(io::writePng(dir / "a.png", img).ok());
  Result<ImageRGBA8> back = io::readPng(dir / "a.png");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->width, 7u);
  EXPECT_EQ(back->height, 5u);
  EXPECT_EQ(back->pixels, img.pixels);
  EXPECT_EQ(entries(dir), 1u); // no temp file left behind
}

TEST(ImageIo, CorruptAndMissingPngRejected) {
  fs::path dir = test::tempDir("png_corrupt");
  std::vector<uint8_t> bytes = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R', 1, 2};
  spit(dir / "bad.png", bytes);
  Result<ImageRGBA8> bad = io::readPng(dir / "bad.png");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message.rfind((dir / "bad.png").string() + ": ", 0), 0u) << bad.error().message;
  Result<ImageRGBA8> missing = io::readPng(dir / "missing.png");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("missing.png"), std::string::npos);
  EXPECT_FALSE(io::readPng(dir).ok()); // a directory
}

TEST(ImageIo, UnwritableDirectoryIsAnErrorAndLeavesNothing) {
  fs::path dir = test::tempDir("png_unwritable");
  ImageRGBA8 img{2, 2, std::vector<uint8_t>(16, 9)};
  Status s = io::writePng(dir / "no_such_dir" / "a.png", img);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("no_such_dir/a.png"), std::string::npos);
  EXPECT_EQ(entries(dir), 0u);
  // Renaming onto a non-empty directory fails after the temp file was written: it must be removed.
  fs::create_directories(dir / "taken.exr" / "x");
  ASSERT_FALSE(io::writeExr(dir / "taken.exr", floatImage(2, 2)).ok());
  EXPECT_EQ(entries(dir), 1u);
  EXPECT_FALSE(io::writePng(dir / "empty.png", ImageRGBA8{}).ok());
  EXPECT_FALSE(fs::exists(dir / "empty.png"));
}

TEST(ImageIo, ExrRoundTripIsBitExact) {
  fs::path dir = test::tempDir("exr_round_trip");
  ImageF32 img = floatImage(13, 9);
  img.pixels[5] = std::numeric_limits<float>::infinity();
  img.pixels[6] = -0.0f;
  img.pixels[7] = 65504.0f * 4;
  ASSERT_TRUE(io::writeExr(dir / "a.exr", img).ok());
  Result<ImageF32> back = io::readExr(dir / "a.exr");
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->width, 13u);
  ASSERT_EQ(back->height, 9u);
  EXPECT_EQ(std::memcmp(back->pixels.data(), img.pixels.data(), img.pixels.size() * 4), 0);
}

TEST(ImageIo, ExrByteLayout) {
  fs::path dir = test::tempDir("exr_layout");
  const uint32_t w = 3, h = 2;
  ImageF32 img = floatImage(w, h);
  ASSERT_TRUE(io::writeExr(dir / "a.exr", img).ok());
  std::vector<uint8_t> b = test::fileBytes(dir / "a.exr");
  ASSERT_GT(b.size(), 8u);
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.begin() + 8), (std::vector<uint8_t>{0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0}));
  // First attribute: channels, chlist, 4 channels x (2 + 16) bytes + terminator.
  const char chlist[] = "channels\0chlist";
  ASSERT_EQ(std::memcmp(&b[8], chlist, sizeof(chlist)), 0);
  EXPECT_EQ(peek<int32_t>(b, 8 + sizeof(chlist)), 73);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[8 + sizeof(chlist) + 4])), "A");
  for (const char* attr : {"compression", "dataWindow", "displayWindow", "lineOrder", "pixelAspectRatio",
                           "screenWindowCenter", "screenWindowWidth"}) {
    std::string needle = std::string(attr) + '\0';
    EXPECT_NE(std::search(b.begin(), b.end(), needle.begin(), needle.end()), b.end()) << attr;
  }
  // The file ends with h chunks of (y, size, A row, B row, G row, R row), preceded by the offset table.
  const size_t chunk = 8 + w * 16, dataStart = b.size() - h * chunk, table = dataStart - h * 8;
  EXPECT_EQ(b[table - 1], 0); // header terminator
  for (uint32_t y = 0; y < h; ++y) {
    uint64_t offset = peek<uint64_t>(b, table + y * 8);
    EXPECT_EQ(offset, dataStart + y * chunk);
    EXPECT_EQ(peek<int32_t>(b, offset), int32_t(y));
    EXPECT_EQ(peek<int32_t>(b, offset + 4), int32_t(w * 16));
    // A channel of pixel 0 comes first, R channel of the last pixel last.
    EXPECT_EQ(peek<float>(b, offset + 8), img.pixels[(y * w) * 4 + 3]);
    EXPECT_EQ(peek<float>(b, offset + 8 + (4 * w - 1) * 4), img.pixels[(y * w + w - 1) * 4 + 0]);
  }
}

TEST(ImageIo, ExrReaderRejectsOtherFiles) {
  fs::path dir = test::tempDir("exr_bad");
  spit(dir / "a.exr", {1, 2, 3, 4, 5, 6, 7, 8, 9});
  EXPECT_FALSE(io::readExr(dir / "a.exr").ok());
  ASSERT_TRUE(io::writeExr(dir / "b.exr", floatImage(4, 4)).ok());
  std::vector<uint8_t> b = test::fileBytes(dir / "b.exr");
  b.resize(b.size() - 10);
  spit(dir / "b.exr", b);
  Result<ImageF32> r = io::readExr(dir / "b.exr");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("b.exr: "), std::string::npos);
}

TEST(ImageIo, PfmIsBottomUpRgb) {
  fs::path dir = test::tempDir("pfm");
  ImageF32 img = floatImage(3, 2);
  ASSERT_TRUE(io::writePfm(dir / "a.pfm", img).ok());
  std::vector<uint8_t> b = test::fileBytes(dir / "a.pfm");
  const std::string header = "PF\n3 2\n-1.0\n";
  ASSERT_EQ(b.size(), header.size() + 3 * 2 * 12);
  EXPECT_EQ(std::string(b.begin(), b.begin() + header.size()), header);
  // First stored pixel is the bottom-left one (row 1), its R, G, B.
  for (int c = 0; c < 3; ++c) EXPECT_EQ(peek<float>(b, header.size() + c * 4), img.pixels[(1 * 3 + 0) * 4 + c]);
  EXPECT_EQ(peek<float>(b, b.size() - 4), img.pixels[(0 * 3 + 2) * 4 + 2]); // top-right B last
}

TEST(ImageIo, SrgbTransfer) {
  for (int i = 0; i < 256; ++i) EXPECT_EQ(io::linearToSrgb8(io::srgb8ToLinear(uint8_t(i))), i);
  EXPECT_EQ(io::srgb8ToLinear(0), 0.0f);
  EXPECT_EQ(io::srgb8ToLinear(255), 1.0f);
  EXPECT_NEAR(io::srgb8ToLinear(128), 0.2158605f, 1e-6f);
  EXPECT_EQ(io::linearToSrgb8(-1.0f), 0);
  EXPECT_EQ(io::linearToSrgb8(7.0f), 255);
  EXPECT_EQ(io::linearToSrgb8(std::nanf("")), 0);
  EXPECT_EQ(io::linearToSrgb8(0.5f), 188);
}
