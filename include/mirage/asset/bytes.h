#pragma once
// Little-endian binary serialization for chunk payloads. ByteWriter appends to a growing buffer;
// ByteReader reads from a span with every read bounds-checked. Reads never touch memory past the
// span: a failed read records a one-line error ("<file>: <problem> at byte N"), leaves the output
// untouched, and makes every later read fail too (sticky), so decoders can read a whole record and
// check once. Counts read from the data are checked against the bytes left *before* allocating, so
// a corrupt count can never trigger a huge allocation.
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::asset {

// Plain values are copied byte for byte. Every platform Mirage targets (x86-64, ARM64) is
// little-endian, so the in-memory representation is the file representation.
static_assert(std::endian::native == std::endian::little, "the .mrg format assumes a little-endian host");

// Types that may be memcpy'd from untrusted bytes: every bit pattern must be a valid value, which
// rules out bool and enums (read them as uint8_t and validate). Types written must have no padding
// (callers static_assert their struct sizes), or indeterminate padding bytes would reach the file.
template <class T>
concept PlainValue = std::is_trivially_copyable_v<T> && !std::is_same_v<T, bool> && !std::is_enum_v<T>;

class ByteWriter {
public:
  void reserve(size_t bytes) { data_.reserve(bytes); }
  size_t size() const { return data_.size(); }
  const std::vector<uint8_t>& data() const { return data_; }
  std::vector<uint8_t> take() { return std::move(data_); }

  template <PlainValue T> void write(const T& value) { writeRaw(&value, sizeof(T)); }
  // Unsigned LEB128: 7 bits per byte, high bit set on all but the last byte; at most 10 bytes.
  void writeVarint(uint64_t value) {
    while (value >= 0x80) {
      data_.push_back(static_cast<uint8_t>(value | 0x80));
      value >>= 7;
    }
    data_.push_back(static_cast<uint8_t>(value));
  }
  // Raw bytes, no length prefix.
  void writeBytes(std::span<const uint8_t> bytes) { writeRaw(bytes.data(), bytes.size()); }
  // Varint length, then the bytes.
  void writeString(std::string_view s) {
    writeVarint(s.size());
    writeRaw(s.data(), s.size());
  }
  // Varint element count, then the elements.
  template <PlainValue T> void writeArray(std::span<const T> values) {
    writeVarint(values.size());
    writeRaw(values.data(), values.size_bytes());
  }

private:
  void writeRaw(const void* p, size_t n) {
    if (n == 0) return; // p may be null for empty spans
    size_t at = data_.size();
    data_.resize(at + n);
    std::memcpy(data_.data() + at, p, n);
  }
  std::vector<uint8_t> data_;
};

class ByteReader {
public:
  // `file` names the source in error messages.
  ByteReader(std::span<const uint8_t> data, std::string file) : data_(data), file_(std::move(file)) {}

  size_t position() const { return pos_; }
  size_t remaining() const { return data_.size() - pos_; }
  bool ok() const { return !failed_; }
  // The first failure; only meaningful when !ok().
  const Error& error() const { return error_; }

  template <PlainValue T> bool read(T& out) { return readRaw(&out, sizeof(T), "value"); }
  bool readVarint(uint64_t& out) {
    uint64_t v = 0;
    for (int i = 0; i < 10; ++i) {
      uint8_t b = 0;
      if (!readRaw(&b, 1, "varint")) return false;
      // The 10th byte holds only bit 63: anything more would overflow (and shifting past 63 is UB).
      if (i == 9 && b > 1) return fail("varint overflows 64 bits");
      // Overlong forms (a trailing zero byte) are rejected so each value has exactly one encoding:
      // whatever decodes re-encodes to the same bytes.
      if (i > 0 && b == 0) return fail("non-canonical varint");
      v |= static_cast<uint64_t>(b & 0x7f) << (7 * i);
      if (!(b & 0x80)) {
        out = v;
        return true;
      }
    }
    return fail("varint longer than 10 bytes");
  }
  // A varint that must be at most `max` (counts, lengths); `what` names it in the error.
  bool readCount(uint64_t& out, uint64_t max, const char* what) {
    uint64_t v = 0;
    if (!readVarint(v)) return false;
    if (v > max) return fail(std::string(what) + " " + std::to_string(v) + " exceeds the limit " + std::to_string(max));
    out = v;
    return true;
  }
  bool readBytes(std::span<uint8_t> out) { return readRaw(out.data(), out.size(), "bytes"); }
  bool skip(size_t n) {
    if (failed_) return false;
    if (n > remaining()) return fail("skip of " + std::to_string(n) + " bytes past the end");
    pos_ += n;
    return true;
  }
  bool readString(std::string& out) {
    uint64_t n = 0;
    if (!readVarint(n)) return false;
    // Compared after the varint is consumed: `remaining()` must describe the bytes that follow it.
    if (n > remaining()) return fail("string length " + std::to_string(n) + " runs past the end");
    out.assign(reinterpret_cast<const char*>(data_.data() + pos_), n);
    pos_ += n;
    return true;
  }
  // Varint count, then the elements; the count is checked against the bytes left before the
  // vector is resized, so the allocation is bounded by the input size.
  template <PlainValue T> bool readArray(std::vector<T>& out) {
    uint64_t n = 0;
    if (!readVarint(n)) return false;
    if (n > remaining() / sizeof(T)) return fail("array length " + std::to_string(n) + " runs past the end");
    out.resize(n);
    return readRaw(out.data(), n * sizeof(T), "array");
  }

  // Record a semantic error found by the caller (e.g. an index out of range); returns false.
  bool fail(const std::string& problem) {
    if (!failed_) {
      failed_ = true;
      error_ = makeError(file_, problem + " at byte " + std::to_string(pos_));
    }
    return false;
  }
  // Success only if every read succeeded and all bytes were consumed (trailing bytes mean the
  // writer and reader disagree about the layout).
  Status finish() {
    if (!failed_ && pos_ != data_.size()) fail(std::to_string(remaining()) + " unexpected trailing bytes");
    if (failed_) return error_;
    return Ok{};
  }

private:
  bool readRaw(void* out, size_t n, const char* what) {
    if (failed_) return false;
    if (n > remaining()) {
      return fail("truncated " + std::string(what) + " (need " + std::to_string(n) + " bytes, " +
                  std::to_string(remaining()) + " left)");
    }
    if (n) std::memcpy(out, data_.data() + pos_, n);
    pos_ += n;
    return true;
  }

  std::span<const uint8_t> data_;
  std::string file_;
  size_t pos_ = 0;
  bool failed_ = false;
  Error error_;
};

} // namespace mirage::asset
