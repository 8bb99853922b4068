// A Frame's patch section (patch_section.h; docs/stream.md, "Patch section"). Every id list is
// strictly increasing and travels as gaps; every entry's position residuals are small integers for
// the usual patch (a few grid steps to a few thousand), so varints and zstd find little left to
// spend bytes on. The decoder checks each count against its limit and the bytes left before it
// sizes a vector, and a zstd frame's declared content size against the limit before it allocates.
#include "patch_section.h"

#include <cassert>
#include <cmath>

#include <glm/glm.hpp>
#include <glm/gtc/type_precision.hpp>
#include <zstd.h>

#include "mirage/shaderio/atlas.h"

namespace mirage::stream {

namespace wire {

namespace {

// Smallest entry sizes in the raw section (bytes): an id gap; an id gap and the head byte; an id
// gap and rgba.
constexpr size_t kRemovedMinBytes = 1;
constexpr size_t kEntryMinBytes = 2;
constexpr size_t kColourMinBytes = 5;

// The head byte of an entry.
constexpr uint8_t kHeadTriangles = 0x03;  // bits 0-1: triangle count 1..3
constexpr uint8_t kHeadAlphaShift = 2;    // bits 2-3: alpha mode 0..2 (0 in block-only entries)
constexpr uint8_t kHeadGeometry = 0x10;   // bit 4: positions follow
constexpr uint8_t kHeadColourOnly = 0x20; // bit 5: no block (drawn in its colour)
constexpr uint8_t kHeadReserved = 0xc0;   // bits 6-7: 0

// zstd level of the patch section: measured on gen:city:4 along orbit:120 (docs/stream.md), higher
// levels save a few percent for several times the time.
constexpr int kZstdLevel = 6;

// The grid point each slot is predicted from: a from the previous geometry entry's a, b and c from
// a, d from the parallelogram b + c - a (exact on a planar rectangle), e from b + d - c.
glm::i64vec3 predict(const std::array<glm::uvec3, 5>& p, uint32_t slot, const glm::i64vec3& previousA) {
  auto at = [&](uint32_t v) { return glm::i64vec3(p[v]); };
  switch (slot) {
  case 0:
    return previousA;
  case 1:
  case 2:
    return at(0);
  case 3:
    return at(1) + at(2) - at(0);
  default:
    return at(1) + at(3) - at(2);
  }
}

template <class T> bool strictlyIncreasing(const std::vector<T>& v, uint32_t (*id)(const T&)) {
  for (size_t i = 1; i < v.size(); ++i)
    if (id(v[i]) <= id(v[i - 1])) return false;
  return true;
}

std::vector<uint8_t> rawSection(const Frame& frame) {
  assert(strictlyIncreasing<uint32_t>(frame.removed, [](const uint32_t& i) { return i; }));
  assert(strictlyIncreasing<PatchUpdate>(frame.updated, [](const PatchUpdate& u) { return u.id; }));
  assert(strictlyIncreasing<PatchColour>(frame.colours, [](const PatchColour& c) { return c.id; }));
  Writer w;
  w.out.reserve(16 + frame.removed.size() * 2 + frame.updated.size() * 24 + frame.colours.size() * 6);
  // Ids as gaps: the first id, then each id minus the previous minus one.
  auto gap = [](uint32_t id, uint64_t& next) {
    uint32_t g = uint32_t(id - next);
    next = uint64_t(id) + 1;
    return g;
  };
  uint64_t next = 0;
  w.varint(uint32_t(frame.removed.size()));
  for (uint32_t id : frame.removed) w.varint(gap(id, next));
  next = 0;
  glm::i64vec3 previousA(0);
  w.varint(uint32_t(frame.updated.size()));
  for (const PatchUpdate& p : frame.updated) {
    w.varint(gap(p.id, next));
    bool colourOnly = p.blockLog2 == kColourOnlyBlock;
    uint8_t head = uint8_t(p.triangleCount & kHeadTriangles);
    if (p.geometry) head |= uint8_t(uint8_t(p.alpha) << kHeadAlphaShift) | kHeadGeometry;
    if (colourOnly) head |= kHeadColourOnly;
    w.u8(head);
    if (!colourOnly) {
      assert(p.blockX % (1u << p.blockLog2) == 0 && p.blockY % (1u << p.blockLog2) == 0);
      w.u8(p.blockLog2);
      w.varint(uint32_t(p.blockX) >> p.blockLog2);
      w.varint(uint32_t(p.blockY) >> p.blockLog2);
    }
    if (!p.geometry) continue;
    for (uint32_t v = 0; v < patchVertexCount(p.triangleCount); ++v) {
      assert(glm::all(glm::lessThanEqual(p.positions[v], glm::uvec3(kPositionGridMax))));
      glm::i64vec3 residual = glm::i64vec3(p.positions[v]) - predict(p.positions, v, previousA);
      for (int k = 0; k < 3; ++k) w.varint(zigzag(int32_t(residual[k])));
    }
    previousA = glm::i64vec3(p.positions[0]);
  }
  next = 0;
  w.varint(uint32_t(frame.colours.size()));
  for (const PatchColour& c : frame.colours) {
    w.varint(gap(c.id, next));
    for (uint8_t channel : c.rgba) w.u8(channel);
  }
  return std::move(w.out);
}

std::vector<uint8_t> compress(std::span<const uint8_t> raw) {
  std::vector<uint8_t> out(ZSTD_compressBound(raw.size()));
  size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), kZstdLevel);
  assert(!ZSTD_isError(n)); // only an undersized output fails, and compressBound sizes it
  out.resize(n);
  return out;
}

// The next id of a strictly increasing list from its gap; false past uint32.
bool nextId(Reader& r, uint64_t& next, uint32_t& id, const std::string& field) {
  uint32_t g = 0;
  if (!r.varint(g, field)) return false;
  uint64_t value = next + g;
  if (value > 0xffffffffull) return r.fail(field, "id past 2^32 - 1");
  id = uint32_t(value);
  next = value + 1;
  return true;
}

bool readEntry(Reader& r, PatchUpdate& p, uint64_t& next, glm::i64vec3& previousA, const DecodeLimits& limits) {
  uint8_t head = 0;
  if (!nextId(r, next, p.id, "id") || !r.u8(head, "head")) return false;
  if (head & kHeadReserved) return r.fail("head", std::to_string(head) + " has reserved bits set");
  p.triangleCount = uint8_t(head & kHeadTriangles);
  if (p.triangleCount == 0) return r.fail("triangleCount", "0 not in 1..3");
  p.geometry = (head & kHeadGeometry) != 0;
  uint8_t alpha = uint8_t((head >> kHeadAlphaShift) & 3);
  if (alpha >= kAlphaModeCount) return r.fail("alpha", std::to_string(alpha) + " not an alpha mode (0..2)");
  if (!p.geometry && alpha != 0) return r.fail("alpha", "set in a block-only entry");
  p.alpha = AlphaMode(alpha);
  if (head & kHeadColourOnly) {
    p.blockLog2 = kColourOnlyBlock;
  } else {
    uint32_t bx = 0, by = 0;
    if (!r.u8(p.blockLog2, "blockLog2")) return false;
    if (p.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
      return r.fail("blockLog2", std::to_string(p.blockLog2) + " not in 1..7");
    if (!r.varint(bx, "blockX") || !r.varint(by, "blockY")) return false;
    uint64_t x = uint64_t(bx) << p.blockLog2, y = uint64_t(by) << p.blockLog2;
    uint64_t width = shaderio::atlasBlockWidth(p.triangleCount, p.blockLog2), height = 1u << p.blockLog2;
    if (x + width > limits.maxAtlasSide || y + height > limits.maxAtlasSide)
      return r.fail("blockX", "block at (" + std::to_string(x) + ", " + std::to_string(y) + ") size " +
                                  std::to_string(width) + "x" + std::to_string(height) + " outside the atlas side " +
                                  std::to_string(limits.maxAtlasSide));
    p.blockX = uint16_t(x);
    p.blockY = uint16_t(y);
  }
  if (!p.geometry) return true;
  for (uint32_t v = 0; v < patchVertexCount(p.triangleCount); ++v) {
    glm::i64vec3 value = predict(p.positions, v, previousA);
    for (int k = 0; k < 3; ++k) {
      std::string field = "positions[" + std::to_string(v) + "]." + "xyz"[k];
      uint32_t z = 0;
      if (!r.varint(z, field)) return false;
      value[k] += unzigzag(z);
      if (value[k] < 0 || value[k] > int64_t(kPositionGridMax))
        return r.fail(field,
                      std::to_string(value[k]) + " outside the grid (0.." + std::to_string(kPositionGridMax) + ")");
    }
    p.positions[v] = glm::uvec3(value);
  }
  previousA = glm::i64vec3(p.positions[0]);
  return true;
}

bool readSection(Reader& r, Frame& m, const DecodeLimits& limits) {
  uint32_t n = 0;
  uint64_t next = 0;
  if (!r.varintCount(n, limits.maxRemovedPerFrame, kRemovedMinBytes, "removed count")) return false;
  m.removed.resize(n);
  for (uint32_t i = 0; i < n; ++i)
    if (!nextId(r, next, m.removed[i], "removed[" + std::to_string(i) + "]")) return false;
  if (!r.varintCount(n, limits.maxPatchesPerFrame, kEntryMinBytes, "updated count")) return false;
  m.updated.resize(n);
  next = 0;
  glm::i64vec3 previousA(0);
  for (uint32_t i = 0; i < n; ++i) {
    if (!readEntry(r, m.updated[i], next, previousA, limits)) {
      r.error = "updated[" + std::to_string(i) + "]." + r.error;
      return false;
    }
  }
  if (!r.varintCount(n, limits.maxColoursPerFrame, kColourMinBytes, "colours count")) return false;
  m.colours.resize(n);
  next = 0;
  for (uint32_t i = 0; i < n; ++i) {
    PatchColour& c = m.colours[i];
    std::string field = "colours[" + std::to_string(i) + "]";
    if (!nextId(r, next, c.id, field + ".id")) return false;
    for (uint8_t& channel : c.rgba)
      if (!r.u8(channel, field + ".rgba")) return false;
  }
  if (r.left() != 0) return r.fail("patches", std::to_string(r.left()) + " bytes after the colours");
  return true;
}

} // namespace

void writeSection(Writer& w, PatchCodec codec, std::vector<uint8_t> raw) {
  w.u8(uint8_t(codec));
  if (codec == PatchCodec::Zstd) raw = compress(raw);
  w.u32(uint32_t(raw.size()));
  w.bytes(raw);
}

bool readSectionContent(Reader& r, const std::string& name, PatchCodec& codecOut, std::vector<uint8_t>& storage,
                        std::span<const uint8_t>& content, const DecodeLimits& limits) {
  uint8_t codec = 0;
  uint32_t byteCount = 0;
  std::span<const uint8_t> bytes;
  if (!r.u8(codec, name + ".codec") || !r.u32(byteCount, name + ".byteCount") ||
      !r.view(bytes, byteCount, name + ".bytes"))
    return false;
  if (codec >= kPatchCodecCount) return r.fail(name + ".codec", std::to_string(codec) + " not 0 (raw) or 1 (zstd)");
  codecOut = PatchCodec(codec);
  if (codecOut == PatchCodec::Zstd) {
    unsigned long long size = ZSTD_getFrameContentSize(bytes.data(), bytes.size());
    if (size == ZSTD_CONTENTSIZE_ERROR) return r.fail(name + ".bytes", "not a zstd frame");
    if (size == ZSTD_CONTENTSIZE_UNKNOWN) return r.fail(name + ".bytes", "zstd frame without its content size");
    if (size > limits.maxPatchSectionBytes)
      return r.fail(name + ".bytes", "zstd content of " + std::to_string(size) + " bytes over the limit of " +
                                         std::to_string(limits.maxPatchSectionBytes));
    size_t frameBytes = ZSTD_findFrameCompressedSize(bytes.data(), bytes.size());
    if (ZSTD_isError(frameBytes) || frameBytes != bytes.size())
      return r.fail(name + ".bytes", "not exactly one zstd frame");
    storage.resize(size_t(size));
    size_t got = ZSTD_decompress(storage.data(), storage.size(), bytes.data(), bytes.size());
    if (ZSTD_isError(got)) return r.fail(name + ".bytes", std::string("corrupt zstd data: ") + ZSTD_getErrorName(got));
    if (got != storage.size())
      return r.fail(name + ".bytes",
                    "zstd frame of " + std::to_string(got) + " bytes, its header says " + std::to_string(size));
    content = storage;
  } else if (byteCount > limits.maxPatchSectionBytes) {
    return r.fail(name + ".byteCount",
                  std::to_string(byteCount) + " over the limit of " + std::to_string(limits.maxPatchSectionBytes));
  } else {
    content = bytes;
  }
  return true;
}

size_t sectionBytes(PatchCodec codec, std::vector<uint8_t> raw) {
  return codec == PatchCodec::Zstd ? compress(raw).size() : raw.size();
}

void writePatchSection(Writer& w, const Frame& frame) { writeSection(w, frame.patchCodec, rawSection(frame)); }

bool readPatchSection(Reader& r, Frame& frame, const DecodeLimits& limits) {
  std::vector<uint8_t> storage;
  std::span<const uint8_t> content;
  if (!readSectionContent(r, "patches", frame.patchCodec, storage, content, limits)) return false;
  Reader section(content);
  if (readSection(section, frame, limits)) return true;
  r.error = section.error;
  return false;
}

} // namespace wire

size_t patchSectionBytes(const Frame& frame) { return wire::sectionBytes(frame.patchCodec, wire::rawSection(frame)); }

float positionGridStep(const glm::vec3& sceneMin, const glm::vec3& sceneMax, uint32_t bits) {
  assert(bits >= 1 && bits <= kPositionGridBits);
  glm::vec3 extent = sceneMax - sceneMin;
  double largest = std::max({double(extent.x), double(extent.y), double(extent.z)});
  double levels = double((1u << bits) - 1);
  if (!(largest > 0.0)) return 1.0f; // a point: any spacing holds it
  // Rounded up so that (2^bits - 1) steps reach the far side despite float rounding.
  float step = float(largest / levels);
  while (double(step) * levels < largest) step = std::nextafter(step, INFINITY);
  return step;
}

glm::uvec3 quantizePosition(const glm::vec3& position, const glm::vec3& sceneMin, float step) {
  glm::uvec3 q;
  for (int k = 0; k < 3; ++k) {
    double cell = std::nearbyint((double(position[k]) - double(sceneMin[k])) / double(step));
    q[k] = uint32_t(std::clamp(cell, 0.0, double(kPositionGridMax)));
  }
  return q;
}

glm::vec3 dequantizePosition(const glm::uvec3& q, const glm::vec3& sceneMin, float step) {
  return sceneMin + glm::vec3(q) * step;
}

} // namespace mirage::stream
