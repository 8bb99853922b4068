// A Frame's particle section (docs/stream.md, "Particle section"): the exact byte layout of a small
// frame, every rule of the decoder on hand-made sections, zstd, and the quantization of positions,
// sizes and rotations.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <glm/gtc/packing.hpp>

#include "mirage/stream/protocol.h"
#include "stream/protocol_test_util.h"

using namespace mirage;
using namespace mirage::stream;

namespace {

// A Frame message (sequence 1, pose 1, an empty patch section, no atlas) around hand-made particle
// section bytes.
std::vector<uint8_t> particleFrameWith(const std::vector<uint8_t>& section, uint8_t codec = 0) {
  std::vector<uint8_t> m = {'M', 'R', 'G', 'S', uint8_t(kProtocolVersion), 0, 4, 0, 0, 0, 0, 0};
  auto u32 = [&](uint32_t v) {
    for (int i = 0; i < 4; ++i) m.push_back(uint8_t(v >> (8 * i)));
  };
  u32(1);
  u32(1);
  u32(0);
  u32(0);
  m.insert(m.end(), {0, 3, 0, 0, 0, 0, 0, 0}); // patches: raw, 3 bytes: nothing removed, updated, coloured
  m.push_back(codec);
  u32(uint32_t(section.size()));
  m.insert(m.end(), section.begin(), section.end());
  m.push_back(0); // atlas codec none, size 0 x 0, no bytes
  u32(0);
  u32(0);
  u32(0);
  uint32_t payload = uint32_t(m.size() - kMessageHeaderBytes);
  for (int i = 0; i < 4; ++i) m[8 + i] = uint8_t(payload >> (8 * i));
  return m;
}

// The particle section of an encoded Frame (empty patch section, no atlas payload).
std::vector<uint8_t> particleSectionOf(const std::vector<uint8_t>& message) {
  size_t at = kMessageHeaderBytes + 16 + 8 + 1 + 4;
  return {message.begin() + ptrdiff_t(at), message.end() - 13};
}

void pushF32(std::vector<uint8_t>& out, float v) {
  uint32_t b = std::bit_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(b >> (8 * i)));
}

// The grid header of a section with particles: origin (0, 0, 0), step 1.
std::vector<uint8_t> gridHeader(float step = 1.0f) {
  std::vector<uint8_t> g;
  for (int k = 0; k < 3; ++k) pushF32(g, 0.0f);
  pushF32(g, step);
  return g;
}

// One particle of look `look` in columns: the look, x, y, z, size, rotation, rgba.
std::vector<uint8_t> oneParticle(uint8_t look, uint16_t size = 0x3c00) {
  return {look, 1, 0, 2, 0, 3, 0, uint8_t(size), uint8_t(size >> 8), 0, 0, 9, 9, 9, 9};
}

std::vector<uint8_t> section(std::vector<uint8_t> looks, std::vector<uint8_t> particles, float step = 1.0f) {
  std::vector<uint8_t> s = std::move(looks);
  if (particles.empty()) {
    s.push_back(0);
    return s;
  }
  s.push_back(1);
  std::vector<uint8_t> g = gridHeader(step);
  s.insert(s.end(), g.begin(), g.end());
  s.insert(s.end(), particles.begin(), particles.end());
  return s;
}

using test::decode;
using test::expectError;

} // namespace

TEST(StreamParticleSection, ExactLayout) {
  Frame f;
  f.looks = {{2, 16, 8, 3, {}}, {5, 0, 0, kColourOnlyBlock, {1, 2, 3, 4}}};
  f.particleOrigin = {1.0f, 2.0f, 3.0f};
  f.particleStep = 0.5f;
  f.particles = {{2, {1, 2, 3}, 0x3c00, 0x4000, {10, 20, 30, 40}}, {5, {0x100, 0, 7}, 0x3800, 0, {5, 6, 7, 8}}};
  std::vector<uint8_t> expected = {
      2,                  // looks
      2, 3,   2, 1,       // id 2; log2 3; (16, 8) / 8
      2, 255, 1, 2, 3, 4, // id 5 (gap 2); colour-only; rgba
      2,                  // particles
  };
  for (float v : {1.0f, 2.0f, 3.0f, 0.5f}) pushF32(expected, v); // origin, step
  expected.insert(expected.end(), {
                                      2,    5,                            // looks
                                      1,    0,    0x00, 0x01,             // x
                                      2,    0,    0,    0,                // y
                                      3,    0,    7,    0,                // z
                                      0x00, 0x3c, 0x00, 0x38,             // sizes: 1.0, 0.5 (halves)
                                      0x00, 0x40, 0,    0,                // rotations
                                      10,   20,   30,   40,   5, 6, 7, 8, // rgba
                                  });
  std::vector<uint8_t> message = encodeMessage(f);
  EXPECT_EQ(particleSectionOf(message), expected);
  EXPECT_EQ(particleSectionBytes(f), expected.size());
  auto back = decode(message);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(std::get<Frame>(*back) == f);
  // No particles: two zeros, no grid.
  EXPECT_EQ(particleSectionOf(encodeMessage(Frame{})), (std::vector<uint8_t>{0, 0}));
}

TEST(StreamParticleSection, Rules) {
  auto look = [](std::vector<uint8_t> l) {
    std::vector<uint8_t> s = {1};
    s.insert(s.end(), l.begin(), l.end());
    return s;
  };
  ASSERT_TRUE(decode(particleFrameWith(section(look({4, 5, 1, 1}), oneParticle(4)))).ok());
  ASSERT_TRUE(decode(particleFrameWith(section({0}, oneParticle(9)))).ok()) << "a look held from an earlier frame";
  expectError(decode(particleFrameWith(section(look({4, 5, 1, 1}), {}))),
              "Frame: looks[0] look 4 is used by no particle of the frame");
  expectError(decode(particleFrameWith(section(look({4, 5, 1, 1}), oneParticle(3)))), "is used by no particle");
  expectError(decode(particleFrameWith(section(look({4, 0, 0, 0}), oneParticle(4)))),
              "Frame: looks[0].blockLog2 0 not in 1..7");
  expectError(decode(particleFrameWith(section(look({4, 8, 0, 0}), oneParticle(4)))), "looks[0].blockLog2 8");
  DecodeLimits small;
  small.maxAtlasSide = 256;
  ASSERT_TRUE(decode(particleFrameWith(section(look({4, 7, 0, 1}), oneParticle(4))), small).ok()) << "wide: 256";
  expectError(decode(particleFrameWith(section(look({4, 7, 1, 1}), oneParticle(4))), small),
              "looks[0].blockX block at (128, 128) size 256x128 outside the atlas side 256");
  expectError(decode(particleFrameWith({1, 4, 255, 1, 2})), "looks[0].rgba: truncated");
  // Ids: strictly increasing (gaps), within 32 bits.
  std::vector<uint8_t> ids = {2, 0xff, 0xff, 0xff, 0xff, 0x0f, 255, 1, 1, 1, 1, 0, 255, 1, 1, 1, 1};
  expectError(decode(particleFrameWith(section(ids, oneParticle(1)))), "looks[1].id past 2^32 - 1");
  // Sizes: finite halves, not negative.
  expectError(decode(particleFrameWith(section({0}, oneParticle(1, 0x7c00)))),
              "Frame: particles[0].size not a finite non-negative half");
  expectError(decode(particleFrameWith(section({0}, oneParticle(1, 0x7e00)))), "particles[0].size not a finite");
  expectError(decode(particleFrameWith(section({0}, oneParticle(1, 0xbc00)))), "particles[0].size not a finite");
  ASSERT_TRUE(decode(particleFrameWith(section({0}, oneParticle(1, 0x7bff)))).ok()) << "the largest half";
  // The grid.
  expectError(decode(particleFrameWith(section({0}, oneParticle(1), 0.0f))), "particles.step 0.000000 not above 0");
  expectError(decode(particleFrameWith(section({0}, oneParticle(1), -1.0f))), "particles.step -1.000000 not above 0");
  expectError(decode(particleFrameWith(section({0}, oneParticle(1), INFINITY))), "particles.step: not a finite");
  // Counts against their limits and the bytes left, trailing bytes, truncation.
  DecodeLimits few;
  few.maxParticlesPerFrame = 1;
  std::vector<uint8_t> two = {0, 2};
  std::vector<uint8_t> g = gridHeader();
  two.insert(two.end(), g.begin(), g.end());
  two.resize(two.size() + 2 * 15, 0);
  expectError(decode(particleFrameWith(two), few), "Frame: particles count 2 over the limit of 1");
  expectError(decode(particleFrameWith({0, 100, 1, 2, 3})), "particles count 100 entries need 1500 bytes, 3 left");
  few.maxLooksPerFrame = 0;
  expectError(decode(particleFrameWith(section(look({4, 5, 1, 1}), oneParticle(4))), few),
              "looks count 1 over the limit of 0");
  expectError(decode(particleFrameWith({9, 1, 1, 1, 1})), "looks count 9 entries need 36 bytes, 4 left");
  std::vector<uint8_t> trailing = section({0}, oneParticle(1));
  trailing.push_back(0);
  expectError(decode(particleFrameWith(trailing)), "Frame: particles 1 bytes after the colours");
  std::vector<uint8_t> cut = section({0}, oneParticle(1));
  cut.pop_back();
  expectError(decode(particleFrameWith(cut)), "particles count 1 entries need 15 bytes, 14 left");
  expectError(decode(particleFrameWith({0})), "particles count: truncated");
  expectError(decode(particleFrameWith({0, 0}, 2)), "Frame: particles.codec 2 not 0 (raw) or 1 (zstd)");
}

TEST(StreamParticleSection, Zstd) {
  Frame f;
  std::mt19937 rng(3);
  f.looks = {{0, 0, 0, 5, {}}, {1, 32, 0, 5, {}}};
  f.particleStep = 1e-3f;
  for (uint32_t i = 0; i < 3000; ++i) // a slow column of smoke: neighbours close, looks in runs
    f.particles.push_back({i / 1500,
                           {uint16_t(30000 + rng() % 200), uint16_t(i * 20), uint16_t(30000 + rng() % 200)},
                           uint16_t(0x3c00 + i / 10),
                           uint16_t(rng()),
                           {180, 180, 180, uint8_t(i / 12)}});
  Frame z = f;
  z.particleCodec = PatchCodec::Zstd;
  std::vector<uint8_t> raw = encodeMessage(f), packed = encodeMessage(z);
  EXPECT_LT(packed.size() * 3, raw.size() * 2) << "columns of like values compress";
  EXPECT_EQ(raw.size() - packed.size(), particleSectionBytes(f) - particleSectionBytes(z));
  auto back = decode(packed);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(std::get<Frame>(*back) == z);
  DecodeLimits tight;
  tight.maxPatchSectionBytes = uint32_t(particleSectionBytes(f) - 1);
  expectError(decode(packed, tight), "particles.bytes zstd content of " + std::to_string(particleSectionBytes(f)));
  expectError(decode(raw, tight), "Frame: particles.byteCount");
  expectError(decode(particleFrameWith({0, 0}, 1)), "particles.bytes not a zstd frame");
}

TEST(StreamParticleSection, Quantization) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> pos(-40.0f, 60.0f), size(0.0f, 9.0f), angle(-20.0f, 20.0f);
  std::vector<glm::vec3> points(500);
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (glm::vec3& p : points) {
    p = {pos(rng), 0.1f * pos(rng), pos(rng)};
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  float step = particleGridStep(lo, hi);
  glm::vec3 extent = hi - lo;
  EXPECT_GE(double(step) * kParticleGridMax, double(std::max({extent.x, extent.y, extent.z}))) << "spans the extent";
  EXPECT_LT(step, 1.001f * std::max({extent.x, extent.y, extent.z}) / float(kParticleGridMax));
  for (const glm::vec3& p : points) {
    float s = size(rng), r = angle(rng);
    StreamParticle q = quantizeParticle(p, s, r, 0x80402010u, 7, lo, step);
    EXPECT_EQ(q.look, 7u);
    EXPECT_EQ(q.rgba, (std::array<uint8_t, 4>{0x10, 0x20, 0x40, 0x80})) << "r in the low byte, exact";
    glm::vec3 back = particlePosition(q, lo, step);
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(back[k] - p[k]), 0.5f * step * 1.001f + 1e-6f);
    EXPECT_LE(std::abs(particleSize(q.size) - s), s / 2048.0f + 1e-7f) << "a half: 11 bits";
    double d = std::remainder(double(particleRotation(q.rotation)) - r, 2.0 * std::numbers::pi);
    EXPECT_LE(std::abs(d), std::numbers::pi / 65536.0 + 1e-6) << "the angle on 65536 steps";
  }
  EXPECT_EQ(quantizeParticle(lo, -1.0f, 0.0f, 0, 0, lo, step).size, 0u) << "a negative size is 0";
  EXPECT_EQ(quantizeParticle(lo, NAN, 0.0f, 0, 0, lo, step).size, 0u);
  EXPECT_EQ(quantizeParticle(lo, 1e9f, 0.0f, 0, 0, lo, step).size, 0x7bffu) << "the largest finite half";
  EXPECT_EQ(particleGridStep(lo, lo), 1.0f) << "one point";
}
