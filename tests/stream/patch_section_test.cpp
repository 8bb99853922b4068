// A Frame's patch section (docs/stream.md, "Patch section"): the exact byte layout of a small frame,
// every rule of the decoder on hand-made sections, zstd, the position grid, and the keep window both
// sides count through KeptPatches.
#include <gtest/gtest.h>

#include <random>

#include <zstd.h>

#include "mirage/stream/kept_patches.h"
#include "mirage/stream/protocol.h"
#include "stream/protocol_test_util.h"

using namespace mirage;
using namespace mirage::stream;

namespace {

void varint(std::vector<uint8_t>& out, uint32_t v) {
  while (v >= 0x80) {
    out.push_back(uint8_t(v | 0x80));
    v >>= 7;
  }
  out.push_back(uint8_t(v));
}

// A Frame message (sequence 1, pose 1, no atlas) around hand-made patch section bytes.
std::vector<uint8_t> frameWith(const std::vector<uint8_t>& section, uint8_t codec = 0) {
  std::vector<uint8_t> m = {'M', 'R', 'G', 'S', uint8_t(kProtocolVersion), 0, 4, 0, 0, 0, 0, 0};
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) m.push_back(uint8_t(v >> (8 * i)));
  };
  u32(1);
  u32(1);
  u32(0);
  u32(0);
  m.push_back(codec);
  u32(uint32_t(section.size()));
  m.insert(m.end(), section.begin(), section.end());
  m.insert(m.end(), {0, 2, 0, 0, 0, 0, 0}); // the particle section: raw, 2 bytes, no looks, no particles
  m.push_back(0);                           // atlas codec none, size 0 x 0, no bytes
  u32(0);
  u32(0);
  u32(0);
  uint32_t payload = uint32_t(m.size() - kMessageHeaderBytes);
  for (int i = 0; i < 4; ++i) m[8 + i] = uint8_t(payload >> (8 * i));
  return m;
}

using test::decode;
using test::expectError;

// The patch section of an encoded Frame (no particles, no atlas payload): its bytes after the codec
// and count, before the empty particle section (7 bytes) and the atlas fields (13).
std::vector<uint8_t> sectionOf(const std::vector<uint8_t>& message) {
  size_t at = kMessageHeaderBytes + 16 + 1 + 4;
  return {message.begin() + ptrdiff_t(at), message.end() - 20};
}

// A wall of `n` quads of `side` grid steps in a row, as a server sends a new wall: geometry entries.
Frame wallFrame(uint32_t n, uint32_t side) {
  Frame f;
  for (uint32_t i = 0; i < n; ++i) {
    PatchUpdate p;
    p.id = 1000 + 2 * i;
    p.triangleCount = 2;
    glm::uvec3 a(5000 + i * side, 7000, 9000);
    p.positions = {a, a + glm::uvec3(side, 0, 0), a + glm::uvec3(0, side, 0), a + glm::uvec3(side, side, 0)};
    p.blockLog2 = 4;
    p.blockX = uint16_t(i % 64 * 16);
    p.blockY = uint16_t(i / 64 * 16);
    f.updated.push_back(p);
  }
  return f;
}

} // namespace

TEST(StreamPatchSection, ExactLayout) {
  Frame f;
  f.removed = {3, 5};
  PatchUpdate quad; // 2 triangles, blend, block log2 4 at (32, 16)
  quad.id = 2;
  quad.triangleCount = 2;
  quad.alpha = stream::AlphaMode::Blend;
  quad.positions = {glm::uvec3(10, 20, 30), glm::uvec3(13, 20, 30), glm::uvec3(10, 24, 30), glm::uvec3(13, 24, 31)};
  quad.blockLog2 = 4;
  quad.blockX = 32;
  quad.blockY = 16;
  PatchUpdate back; // block-only, colour-only
  back.id = 9;
  back.triangleCount = 1;
  back.geometry = false;
  back.blockLog2 = kColourOnlyBlock;
  f.updated = {quad, back};
  f.colours = {{9, {1, 2, 3, 4}}};
  std::vector<uint8_t> expected = {
      2,  3,    1,           // removed: count, id 3, gap 1 (id 5)
      2,                     // entries
      2,  0x1a, 4,  2, 1,    // id 2; head 2 triangles | blend << 2 | positions; log2 4; (32, 16) / 16
      20, 40,   60,          // a = (10, 20, 30) from (0, 0, 0), zigzag
      6,  0,    0,           // b - a = (3, 0, 0)
      0,  8,    0,           // c - a = (0, 4, 0)
      0,  0,    2,           // d - (b + c - a) = (0, 0, 1)
      6,  0x21,              // id 9 (gap 6); head 1 triangle | colour-only, no positions
      1,  9,    1,  2, 3, 4, // colours: count, id 9, rgba
  };
  std::vector<uint8_t> message = encodeMessage(f);
  EXPECT_EQ(sectionOf(message), expected);
  EXPECT_EQ(patchSectionBytes(f), expected.size());
  auto back2 = decode(message);
  ASSERT_TRUE(back2.ok()) << back2.error().message;
  EXPECT_TRUE(std::get<Frame>(*back2) == f);
}

TEST(StreamPatchSection, VarintsAndIds) {
  expectError(decode(frameWith({0x80, 0x00, 0, 0})), "Frame: removed count varint not in its shortest form");
  expectError(decode(frameWith({0xff, 0xff, 0xff, 0xff, 0x1f})), "removed count varint longer than 32 bits");
  std::vector<uint8_t> s = {2};
  varint(s, 0xffffffffu);
  s.insert(s.end(), {0, 0, 0}); // a second id past 2^32 - 1
  expectError(decode(frameWith(s)), "removed[1] id past 2^32 - 1");
  s = {};
  varint(s, 0xffffffffu);
  expectError(decode(frameWith(s)), "Frame: removed count 4294967295 over the limit");
  // Within the limit, but more entries than bytes left: rejected before anything is allocated.
  expectError(decode(frameWith({100, 1, 2, 3})), "removed count 100 entries need 100 bytes, 3 left");
  expectError(decode(frameWith({0, 50, 1, 0x21, 0})), "updated count 50 entries need 100 bytes");
  expectError(decode(frameWith({0, 0, 9, 1, 2, 3, 4, 5})), "colours count 9 entries need 45 bytes");
  expectError(decode(frameWith({0, 0, 0, 7})), "Frame: patches 1 bytes after the colours");
  expectError(decode(frameWith({0, 0})), "colours count: truncated");
}

TEST(StreamPatchSection, EntryRules) {
  auto entry = [](std::vector<uint8_t> e) {
    std::vector<uint8_t> s = {0, 1};
    s.insert(s.end(), e.begin(), e.end());
    s.push_back(0); // no colours
    return frameWith(s);
  };
  ASSERT_TRUE(decode(entry({4, 0x21})).ok()) << "a block-only colour-only entry";
  expectError(decode(entry({4, 0x20})), "Frame: updated[0].triangleCount 0 not in 1..3");
  expectError(decode(entry({4, 0x61})), "updated[0].head 97 has reserved bits set");
  expectError(decode(entry({4, 0x3d, 0, 0, 0, 0, 0, 0, 0, 0, 0})), "updated[0].alpha 3 not an alpha mode");
  expectError(decode(entry({4, 0x25})), "updated[0].alpha set in a block-only entry");
  expectError(decode(entry({4, 0x01, 0, 0, 0})), "updated[0].blockLog2 0 not in 1..7");
  expectError(decode(entry({4, 0x01, 8, 0, 0})), "updated[0].blockLog2 8 not in 1..7");
  ASSERT_TRUE(decode(entry({4, 0x03, 6, 127, 0})).ok()) << "a wide block at the atlas's right edge";
  expectError(decode(entry({4, 0x03, 6, 0xff, 1, 0})), "updated[0].blockX block at (16320, 0) size 128x64 outside");
  DecodeLimits small;
  small.maxAtlasSide = 256;
  ASSERT_TRUE(decode(entry({4, 0x01, 7, 1, 1}), small).ok());
  expectError(decode(entry({4, 0x01, 7, 2, 1}), small), "block at (256, 128) size 128x128 outside the atlas side 256");
  // Positions: one below the grid, one past it.
  expectError(decode(entry({4, 0x31, 1, 0, 0, 0, 0, 0, 0, 0, 0})), "updated[0].positions[0].x -1 outside the grid");
  std::vector<uint8_t> past = {4, 0x31, 0, 0};
  varint(past, 2 * (kPositionGridMax + 1)); // a.z = 2^24
  expectError(decode(entry(past)), "updated[0].positions[0].z 16777216 outside the grid (0..16777215)");
  expectError(decode(entry({4, 0x31, 0, 0, 0, 0, 0, 0})), // the colour count read as c.x
              "updated[0].positions[2].y: truncated");
}

TEST(StreamPatchSection, Zstd) {
  Frame f = wallFrame(3000, 300);
  f.removed = {1, 2, 3};
  f.colours = {{5, {9, 9, 9, 255}}};
  Frame z = f;
  z.patchCodec = PatchCodec::Zstd;
  std::vector<uint8_t> raw = encodeMessage(f), zstd = encodeMessage(z);
  EXPECT_LT(zstd.size() * 4, raw.size()) << "a regular wall compresses well";
  EXPECT_EQ(raw.size() - zstd.size(), patchSectionBytes(f) - patchSectionBytes(z));
  auto back = decode(zstd);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(std::get<Frame>(*back) == z);

  std::vector<uint8_t> section = sectionOf(raw);
  DecodeLimits tight;
  tight.maxPatchSectionBytes = uint32_t(section.size() - 1);
  expectError(decode(raw, tight), "Frame: patches.byteCount " + std::to_string(section.size()) + " over the limit");
  expectError(decode(zstd, tight),
              "patches.bytes zstd content of " + std::to_string(section.size()) + " bytes over the limit");

  std::vector<uint8_t> packed(ZSTD_compressBound(section.size()));
  packed.resize(ZSTD_compress(packed.data(), packed.size(), section.data(), section.size(), 1));
  ASSERT_TRUE(decode(frameWith(packed, 1)).ok()) << "any zstd frame of the content decodes";
  expectError(decode(frameWith(section, 1)), "patches.bytes not a zstd frame");
  std::vector<uint8_t> twice = packed;
  twice.insert(twice.end(), packed.begin(), packed.end());
  expectError(decode(frameWith(twice, 1)), "not exactly one zstd frame");
  std::vector<uint8_t> cut(packed.begin(), packed.end() - 1);
  expectError(decode(frameWith(cut, 1)), "not exactly one zstd frame");
  std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> context(ZSTD_createCCtx(), ZSTD_freeCCtx);
  ZSTD_CCtx_setParameter(context.get(), ZSTD_c_contentSizeFlag, 0);
  std::vector<uint8_t> unsized(ZSTD_compressBound(section.size()));
  ZSTD_outBuffer out{unsized.data(), unsized.size(), 0};
  ZSTD_inBuffer in{section.data(), section.size(), 0};
  ASSERT_EQ(ZSTD_compressStream2(context.get(), &out, &in, ZSTD_e_end), 0u);
  unsized.resize(out.pos);
  expectError(decode(frameWith(unsized, 1)), "zstd frame without its content size");
  expectError(decode(frameWith(section, 2)), "Frame: patches.codec 2 not 0 (raw) or 1 (zstd)");
}

TEST(StreamPatchSection, BlockOnlyEntriesAreSmall) {
  // What a moved patch costs against the same patch sent with its positions.
  Frame moved = wallFrame(1000, 300);
  for (PatchUpdate& p : moved.updated) {
    p.geometry = false;
    p.positions = {};
  }
  size_t full = patchSectionBytes(wallFrame(1000, 300)), blockOnly = patchSectionBytes(moved);
  EXPECT_LE(blockOnly, 1000u * 5 + 6) << "id gap, head, log2 and two block coordinates";
  EXPECT_GT(full, 3 * blockOnly);
}

TEST(StreamPatchSection, PositionGrid) {
  glm::vec3 lo(-160.0f, 0.0f, -160.0f), hi(160.0f, 49.1f, 160.0f);
  for (uint32_t bits : {8u, 16u, 20u, 24u}) {
    float step = positionGridStep(lo, hi, bits);
    double levels = double((1u << bits) - 1);
    EXPECT_GE(double(step) * levels, 320.0) << bits << " bits: the grid spans the bounds";
    EXPECT_LE(double(step) * levels, 320.0 * (1.0 + 1e-6)) << bits << " bits: and no more";
    EXPECT_GE(quantizePosition(hi, lo, step).x, (1u << bits) - 2) << "the far side (the step is rounded up)";
    EXPECT_LE(quantizePosition(hi, lo, step).x, (1u << bits) - 1);
    EXPECT_EQ(quantizePosition(lo, lo, step), glm::uvec3(0));
    std::mt19937 rng(bits);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    float worst = 0.0f;
    for (int i = 0; i < 10000; ++i) {
      glm::vec3 p = lo + (hi - lo) * glm::vec3(u(rng), u(rng), u(rng));
      glm::vec3 back = dequantizePosition(quantizePosition(p, lo, step), lo, step);
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(back[k] - p[k]));
    }
    // Half a step, plus float rounding of positions up to 160 (2^-16 relative at most).
    EXPECT_LE(worst, step * 0.5f + 160.0f * 0x1p-22f) << bits << " bits";
  }
  EXPECT_EQ(positionGridStep(glm::vec3(1.0f), glm::vec3(1.0f), 20), 1.0f) << "a point";
  EXPECT_EQ(quantizePosition(glm::vec3(-1e9f), lo, 1.0f), glm::uvec3(0)) << "clamped";
  EXPECT_EQ(quantizePosition(glm::vec3(1e9f), lo, 1.0f), glm::uvec3(kPositionGridMax)) << "clamped";
}

TEST(StreamKeptPatches, KeepWindow) {
  KeptPatches<int> kept;
  kept.beginFrame(1);
  kept.keep(7, 70);
  kept.keep(8, 80);
  kept.beginFrame(2);
  kept.keep(9, 90);
  EXPECT_EQ(kept.take(8), 80) << "re-added in the next frame";
  EXPECT_FALSE(kept.take(8)) << "taken once";
  kept.beginFrame(3);
  kept.keep(8, 81);                     // removed again: kept from frame 3
  kept.beginFrame(kKeptGeometryFrames); // frame 1 + K - 1: everything still kept
  EXPECT_TRUE(kept.contains(7));
  EXPECT_EQ(kept.size(), 3u);
  kept.beginFrame(kKeptGeometryFrames + 1); // removed in frame 1: dropped
  EXPECT_FALSE(kept.contains(7));
  EXPECT_TRUE(kept.contains(9));
  EXPECT_TRUE(kept.contains(8)) << "its frame-1 removal was undone; the frame-3 one still holds";
  kept.beginFrame(kKeptGeometryFrames + 2);
  EXPECT_FALSE(kept.contains(9));
  EXPECT_TRUE(kept.contains(8));
  kept.beginFrame(kKeptGeometryFrames + 3);
  EXPECT_EQ(kept.size(), 0u);
  kept.beginFrame(10 * kKeptGeometryFrames); // frames skipped at once
  kept.keep(1, 10);
  kept.beginFrame(11 * kKeptGeometryFrames);
  EXPECT_EQ(kept.size(), 0u);
}
