// ByteWriter/ByteReader: exact encodings, bounds, sticky errors, and counts that must fail
// before allocating.
#include <gtest/gtest.h>

#include <limits>

#include <glm/glm.hpp>

#include "mirage/asset/bytes.h"

using namespace mirage;
using namespace mirage::asset;

TEST(Bytes, VarintEncodingsAndRoundTrip) {
  const std::pair<uint64_t, size_t> cases[] = {
      {0, 1},     {1, 1},     {127, 1},         {128, 2},
      {16383, 2}, {16384, 3}, {1ull << 63, 10}, {std::numeric_limits<uint64_t>::max(), 10}};
  for (auto [value, length] : cases) {
    ByteWriter w;
    w.writeVarint(value);
    EXPECT_EQ(w.size(), length) << value;
    ByteReader r(w.data(), "v");
    uint64_t back = 0;
    ASSERT_TRUE(r.readVarint(back));
    EXPECT_EQ(back, value);
    EXPECT_TRUE(r.finish().ok());
  }
  ByteWriter w;
  w.writeVarint(300);
  EXPECT_EQ(w.data(), (std::vector<uint8_t>{0xac, 0x02})); // the LEB128 example
}

TEST(Bytes, VarintRejectsOverlongAndOverflow) {
  std::vector<uint8_t> overlong(11, 0x80);
  overlong.back() = 0;
  ByteReader a(overlong, "f");
  uint64_t v = 0;
  EXPECT_FALSE(a.readVarint(v));
  std::vector<uint8_t> overflow(9, 0xff);
  overflow.push_back(0x02); // bit 64
  ByteReader b(overflow, "f");
  EXPECT_FALSE(b.readVarint(v));
  EXPECT_NE(b.error().message.find("overflows"), std::string::npos) << b.error().message;
  std::vector<uint8_t> nonCanonical{0x81, 0x00}; // 1 written in two bytes
  ByteReader d(nonCanonical, "f");
  EXPECT_FALSE(d.readVarint(v));
  EXPECT_NE(d.error().message.find("non-canonical"), std::string::npos);
  std::vector<uint8_t> unterminated{0x80, 0x80};
  ByteReader c(unterminated, "f");
  EXPECT_FALSE(c.readVarint(v));
}

TEST(Bytes, PlainValuesStringsArraysRoundTrip) {
  ByteWriter w;
  w.write(uint32_t(0xdeadbeef));
  w.write(-2.5f);
  w.write(glm::vec3(1, 2, 3));
  w.writeString("hello");
  w.writeString("");
  std::vector<uint32_t> values{1, 2, 3, 0xffffffff};
  w.writeArray(std::span<const uint32_t>(values));
  w.writeArray(std::span<const uint32_t>());

  ByteReader r(w.data(), "f");
  uint32_t u = 0;
  float f = 0;
  glm::vec3 v{};
  std::string s1, s2 = "x";
  std::vector<uint32_t> a1, a2{9};
  EXPECT_TRUE(r.read(u) && r.read(f) && r.read(v) && r.readString(s1) && r.readString(s2) && r.readArray(a1) &&
              r.readArray(a2));
  EXPECT_TRUE(r.finish().ok());
  EXPECT_EQ(u, 0xdeadbeef);
  EXPECT_EQ(f, -2.5f);
  EXPECT_EQ(v, glm::vec3(1, 2, 3));
  EXPECT_EQ(s1, "hello");
  EXPECT_EQ(s2, "");
  EXPECT_EQ(a1, values);
  EXPECT_TRUE(a2.empty());
}

TEST(Bytes, ReadPastEndFailsStickyAndLeavesOutputUntouched) {
  std::vector<uint8_t> data{1, 2, 3};
  ByteReader r(data, "short.bin");
  uint32_t u = 42;
  EXPECT_FALSE(r.read(u));
  EXPECT_EQ(u, 42u);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.rfind("short.bin: truncated", 0), 0u) << r.error().message;
  uint8_t b = 7;
  EXPECT_FALSE(r.read(b)); // sticky: even a read that would fit fails after an error
  EXPECT_EQ(b, 7);
  EXPECT_FALSE(r.finish().ok());
}

TEST(Bytes, HugeCountsFailBeforeAllocating) {
  for (uint64_t count : {uint64_t(1) << 40, uint64_t(1) << 62, std::numeric_limits<uint64_t>::max()}) {
    ByteWriter w;
    w.writeVarint(count);
    w.write(uint32_t(0));
    std::vector<uint32_t> out;
    ByteReader r(w.data(), "f");
    EXPECT_FALSE(r.readArray(out));
    EXPECT_TRUE(out.empty());
    std::string s;
    ByteReader r2(w.data(), "f");
    EXPECT_FALSE(r2.readString(s));
  }
  // A string whose length counts its own varint byte must fail: the check is after the varint.
  std::vector<uint8_t> self{2, 'a'};
  ByteReader r(self, "f");
  std::string s;
  EXPECT_FALSE(r.readString(s));
}

TEST(Bytes, FinishRejectsTrailingBytesAndCountLimits) {
  std::vector<uint8_t> data{5, 0};
  ByteReader r(data, "f");
  uint64_t n = 0;
  EXPECT_FALSE(r.readCount(n, 4, "widgets"));
  EXPECT_NE(r.error().message.find("widgets 5 exceeds"), std::string::npos);
  ByteReader r2(data, "f");
  uint8_t b = 0;
  EXPECT_TRUE(r2.read(b));
  Status st = r2.finish();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("trailing"), std::string::npos);
}
