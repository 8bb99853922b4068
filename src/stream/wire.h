#pragma once
// Byte-level writing and bounds-checked reading of the stream protocol (protocol.cpp, the messages;
// patch_section.cpp, a Frame's patch section). Little-endian fixed-width fields, IEEE float32, and
// unsigned LEB128 varints of at most 32 bits in their shortest form (the decoder rejects longer
// ones, so every value has one encoding).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "mirage/stream/protocol.h"

namespace mirage::stream::wire {

struct Writer {
  std::vector<uint8_t> out;
  void u8(uint8_t v) { out.push_back(v); }
  void u16(uint16_t v) {
    for (int i = 0; i < 2; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(uint8_t(v >> (8 * i)));
  }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void vec3(const glm::vec3& v) {
    f32(v.x);
    f32(v.y);
    f32(v.z);
  }
  // Seven bits a byte, low first; the high bit says another byte follows.
  void varint(uint32_t v) {
    while (v >= 0x80) {
      out.push_back(uint8_t(v | 0x80));
      v >>= 7;
    }
    out.push_back(uint8_t(v));
  }
  void bytes(std::span<const uint8_t> b) { out.insert(out.end(), b.begin(), b.end()); }
  // Strings longer than a uint16 length can say are cut: the decoder's limits are far below that.
  void str16(std::string_view s) {
    size_t n = std::min<size_t>(s.size(), 0xffff);
    u16(uint16_t(n));
    out.insert(out.end(), s.begin(), s.begin() + ptrdiff_t(n));
  }
  void camera(const Camera& c) {
    vec3(c.eye);
    vec3(c.target);
    vec3(c.up);
    f32(c.fovY);
  }
};

// A bounds-checked cursor over one payload. A failed read leaves `error` naming the field.
class Reader {
public:
  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}
  std::string error;

  size_t left() const { return bytes_.size() - pos_; }
  bool need(size_t n, std::string_view field) {
    if (n <= left()) return true;
    error =
        std::string(field) + ": truncated (needs " + std::to_string(n) + " bytes, " + std::to_string(left()) + " left)";
    return false;
  }
  bool u8(uint8_t& v, std::string_view field) {
    if (!need(1, field)) return false;
    v = bytes_[pos_++];
    return true;
  }
  bool u16(uint16_t& v, std::string_view field) {
    if (!need(2, field)) return false;
    v = uint16_t(bytes_[pos_] | (bytes_[pos_ + 1] << 8));
    pos_ += 2;
    return true;
  }
  bool u32(uint32_t& v, std::string_view field) {
    if (!need(4, field)) return false;
    v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(bytes_[pos_ + i]) << (8 * i);
    pos_ += 4;
    return true;
  }
  bool u64(uint64_t& v, std::string_view field) {
    if (!need(8, field)) return false;
    v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(bytes_[pos_ + i]) << (8 * i);
    pos_ += 8;
    return true;
  }
  // Finite floats only: a NaN or infinity reaching a view matrix or a vertex is never meant.
  bool f32(float& v, std::string_view field) {
    uint32_t bits = 0;
    if (!u32(bits, field)) return false;
    v = std::bit_cast<float>(bits);
    if (std::isfinite(v)) return true;
    error = std::string(field) + ": not a finite number";
    return false;
  }
  bool vec3(glm::vec3& v, std::string_view field) {
    return f32(v.x, std::string(field) + ".x") && f32(v.y, std::string(field) + ".y") &&
           f32(v.z, std::string(field) + ".z");
  }
  // At most five bytes, a fifth byte below 0x10 (32 bits), and no trailing zero byte (shortest form).
  bool varint(uint32_t& v, std::string_view field) {
    uint32_t value = 0;
    for (int i = 0;; ++i) {
      if (!need(1, field)) return false;
      uint8_t b = bytes_[pos_++];
      if (i == 4 && b > 0x0f) return fail(field, "varint longer than 32 bits");
      value |= uint32_t(b & 0x7f) << (7 * i);
      if (b & 0x80) continue;
      if (b == 0 && i > 0) return fail(field, "varint not in its shortest form");
      v = value;
      return true;
    }
  }
  bool str16(std::string& s, uint32_t maxBytes, std::string_view field) {
    uint16_t n = 0;
    if (!u16(n, std::string(field) + " length")) return false;
    if (n > maxBytes)
      return fail(field, "length " + std::to_string(n) + " over the limit of " + std::to_string(maxBytes));
    if (!need(n, field)) return false;
    s.assign(reinterpret_cast<const char*>(bytes_.data() + pos_), n);
    pos_ += n;
    return true;
  }
  bool bytes(std::vector<uint8_t>& out, size_t n, std::string_view field) {
    if (!need(n, field)) return false;
    out.assign(bytes_.begin() + ptrdiff_t(pos_), bytes_.begin() + ptrdiff_t(pos_ + n));
    pos_ += n;
    return true;
  }
  // `n` bytes in place (valid while the payload is).
  bool view(std::span<const uint8_t>& out, size_t n, std::string_view field) {
    if (!need(n, field)) return false;
    out = bytes_.subspan(pos_, n);
    pos_ += n;
    return true;
  }
  // Checks a count of entries of at least `entryBytes` each: within `limit` and the bytes left.
  bool checkCount(uint32_t n, uint32_t limit, size_t entryBytes, std::string_view field) {
    if (n > limit) return fail(field, std::to_string(n) + " over the limit of " + std::to_string(limit));
    if (uint64_t(n) * entryBytes > left())
      return fail(field, std::to_string(n) + " entries need " + std::to_string(uint64_t(n) * entryBytes) + " bytes, " +
                             std::to_string(left()) + " left");
    return true;
  }
  bool count(uint32_t& n, uint32_t limit, size_t entryBytes, std::string_view field) {
    return u32(n, field) && checkCount(n, limit, entryBytes, field);
  }
  bool varintCount(uint32_t& n, uint32_t limit, size_t entryBytes, std::string_view field) {
    return varint(n, field) && checkCount(n, limit, entryBytes, field);
  }
  bool fail(std::string_view field, const std::string& problem) {
    error = std::string(field) + " " + problem;
    return false;
  }

private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

// Signed residuals as unsigned varints: 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...
inline uint32_t zigzag(int32_t v) { return (uint32_t(v) << 1) ^ uint32_t(v >> 31); }
inline int32_t unzigzag(uint32_t v) { return int32_t(v >> 1) ^ -int32_t(v & 1); }

} // namespace mirage::stream::wire
