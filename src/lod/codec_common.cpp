#include "codec_common.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include <meshoptimizer.h>

namespace mirage::lod::detail {

using asset::ByteReader;
using asset::ByteWriter;

namespace {

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }
int64_t unzigzag(uint64_t v) { return int64_t(v >> 1) ^ -int64_t(v & 1); }

// Open-addressing hash set of the decoded positions: linear time (a sort of the indices per tried
// bit count was an eighth of the whole `mirage build` of the dragon, run once per bit count
// tried). Compared as decoded floats, not grid points: far from the origin two grid points can
// round to one float.
bool positionsDistinct(const PositionGrid& q, const std::vector<PackedPosition>& packed) {
  auto bitsOf = [&](uint32_t i) {
    glm::vec3 p = unpackPosition(q, packed[i]) + glm::vec3(0.0f); // -0 and +0 are one position
    std::array<uint32_t, 3> b;
    std::memcpy(b.data(), &p, sizeof(p));
    return b;
  };
  size_t size = 16;
  while (size < packed.size() * 2) size *= 2;
  std::vector<uint32_t> slots(size, ~0u);
  for (uint32_t i = 0; i < packed.size(); ++i) {
    std::array<uint32_t, 3> p = bitsOf(i);
    uint64_t h = (uint64_t(p[0]) * 0x9e3779b97f4a7c15ull) ^ (uint64_t(p[1]) * 0xc2b2ae3d27d4eb4full) ^
                 (uint64_t(p[2]) * 0x165667b19e3779f9ull);
    h ^= h >> 29;
    for (size_t s = size_t(h) & (size - 1);; s = (s + 1) & (size - 1)) {
      if (slots[s] == ~0u) {
        slots[s] = i;
        break;
      }
      if (bitsOf(slots[s]) == p) return false;
    }
  }
  return true;
}

// The grid of `bits` per axis over `box`: step = largest extent / (2^bits - 1), rounded up as a
// float so that the top coordinate lands on the last grid point, not one past it (rounded to
// nearest, the step was too small for about 10 % of boxes at 23 bits).
PositionGrid makeGrid(const Bounds& box, uint32_t bits) {
  PositionGrid q;
  q.bits = bits;
  if (box.empty()) return q;
  q.origin = box.min;
  double extent = 0.0; // in double: max - min of two floats is exact there
  for (int a = 0; a < 3; ++a) extent = std::max(extent, double(box.max[a]) - double(box.min[a]));
  double cells = double((1u << bits) - 1);
  q.step = std::max(float(extent / cells), std::numeric_limits<float>::min());
  while (double(q.step) * cells < extent) q.step = std::nextafter(q.step, std::numeric_limits<float>::infinity());
  return q;
}

// Quantizes `positions` on `q`, true when the result decodes within positionSlack of every
// original and keeps distinct positions distinct (fused ones would change the topology).
bool quantize(const std::vector<glm::vec3>& positions, const PositionGrid& q, std::vector<PackedPosition>& packed) {
  float slack = positionSlack(q);
  if (!std::isfinite(slack)) return false; // coordinates near the float range: the decoder would refuse it
  for (size_t i = 0; i < positions.size(); ++i) {
    packed[i] = packPosition(q, positions[i]);
    if (!(glm::distance(unpackPosition(q, packed[i]), positions[i]) <= slack)) return false;
  }
  return positionsDistinct(q, packed);
}

} // namespace

void writeIds(ByteWriter& w, std::span<const uint32_t> ids) {
  w.writeVarint(ids.size());
  int64_t prev = 0;
  for (uint32_t id : ids) {
    w.writeVarint(zigzag(int64_t(id) - prev));
    prev = id;
  }
}

bool readIds(ByteReader& r, std::vector<uint32_t>& out, uint64_t limit, const char* what) {
  uint64_t n = 0;
  if (!r.readCount(n, std::min<uint64_t>(limit, r.remaining()), what)) return false;
  out.resize(n);
  int64_t prev = 0;
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t z = 0;
    if (!r.readVarint(z)) return false;
    int64_t v = prev + unzigzag(z);
    if (v < 0 || v > int64_t(UINT32_MAX)) return r.fail(std::string(what) + " id out of range");
    out[i] = uint32_t(v);
    prev = v;
  }
  return true;
}

void writeVertexStream(ByteWriter& w, const void* vertices, size_t count, size_t stride) {
  std::vector<uint8_t> buffer(meshopt_encodeVertexBufferBound(count, stride));
  buffer.resize(meshopt_encodeVertexBuffer(buffer.data(), buffer.size(), vertices, count, stride));
  w.writeVarint(buffer.size());
  w.writeBytes(buffer);
}

bool readVertexStream(ByteReader& r, std::span<const uint8_t> all, void* out, size_t count, size_t stride) {
  uint64_t size = 0;
  if (!r.readCount(size, r.remaining(), "vertex stream size")) return false;
  const uint8_t* data = all.data() + r.position();
  if (!r.skip(size)) return false;
  if (meshopt_decodeVertexBuffer(out, count, stride, data, size) != 0) return r.fail("corrupt vertex stream");
  return true;
}

PositionGrid choosePositionGrid(const std::vector<glm::vec3>& positions, uint32_t requestedBits,
                                std::vector<PackedPosition>& packed) {
  // Positions on a grid over the bounds. Distinct welded positions must stay distinct, or the
  // decoded mesh would change topology (two vertices fused into one): take more bits until none
  // collide.
  Bounds box;
  for (const glm::vec3& p : positions) box.add(p);
  packed.resize(positions.size());
  for (uint32_t bits = requestedBits > kMaxGridBits ? kRawPositionBits : std::max(requestedBits, 8u);
       bits <= kMaxGridBits; ++bits) {
    PositionGrid q = makeGrid(box, bits);
    if (quantize(positions, q, packed)) return q;
  }
  // Vertices closer than 1/2^24 of the extent but not equal (float noise in the source), or a
  // mesh so far from the origin that float rounding of the grid exceeds its step: only the exact
  // floats keep them.
  static_assert(sizeof(PackedPosition) == sizeof(glm::vec3));
  if (!positions.empty()) std::memcpy(packed.data(), positions.data(), packed.size() * sizeof(glm::vec3));
  return PositionGrid{};
}

PackedPosition packPosition(const PositionGrid& q, glm::vec3 p) {
  PackedPosition out;
  if (q.raw()) {
    std::memcpy(&out, &p, sizeof(out));
    return out;
  }
  double maxGrid = double((1u << q.bits) - 1);
  uint32_t g[3];
  for (int a = 0; a < 3; ++a) {
    double t = (double(p[a]) - double(q.origin[a])) / double(q.step);
    g[a] = uint32_t(std::clamp(std::nearbyint(t), 0.0, maxGrid));
  }
  return {g[0], g[1], g[2]};
}

glm::vec3 unpackPosition(const PositionGrid& q, const PackedPosition& p) {
  if (q.raw()) {
    glm::vec3 out;
    std::memcpy(&out, &p, sizeof(out));
    return out;
  }
  return q.origin + glm::vec3(float(p.x), float(p.y), float(p.z)) * q.step;
}

// Half a step per axis (sqrt(3)/2 step in all) plus the float rounding of the product and the
// sum, at most 2^-24 of the largest coordinate each per axis. The encoder only keeps a grid that
// meets it; the decoder widens every sphere and error by it.
float positionSlack(const PositionGrid& q) {
  if (q.raw()) return 0.0f;
  float top = q.step * float((1u << q.bits) - 1);
  float magnitude = std::max({std::abs(q.origin.x), std::abs(q.origin.y), std::abs(q.origin.z)}) + top;
  return q.step + std::ldexp(magnitude, -22);
}

bool gridValid(const PositionGrid& q) {
  if (q.raw()) return true;
  return q.bits >= 8 && q.bits <= kMaxGridBits && q.step > 0.0f && std::isfinite(q.step) && std::isfinite(q.origin.x) &&
         std::isfinite(q.origin.y) && std::isfinite(q.origin.z) && std::isfinite(positionSlack(q));
}

bool packedValid(const PositionGrid& q, const PackedPosition& p) {
  if (q.raw()) {
    glm::vec3 v = unpackPosition(q, p);
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
  }
  uint32_t maxGrid = (1u << q.bits) - 1;
  return p.x <= maxGrid && p.y <= maxGrid && p.z <= maxGrid;
}

void writeGrid(ByteWriter& w, const PositionGrid& q) {
  w.write(q.bits);
  w.write(q.origin.x), w.write(q.origin.y), w.write(q.origin.z), w.write(q.step);
}

bool readGrid(ByteReader& r, PositionGrid& q) {
  return r.read(q.bits) && r.read(q.origin.x) && r.read(q.origin.y) && r.read(q.origin.z) && r.read(q.step);
}

LodBounds widenGroupBounds(LodBounds b, uint32_t groupLevel, float slack) {
  b.radius += slack * float(groupLevel + 2);
  b.error += slack;
  return b;
}

float widenClusterRadius(float radius, float slack) { return radius + slack; }

void writeSphere(ByteWriter& w, const LodBounds& b) {
  w.write(b.center.x), w.write(b.center.y), w.write(b.center.z), w.write(b.radius);
}
bool readSphere(ByteReader& r, LodBounds& b) {
  return r.read(b.center.x) && r.read(b.center.y) && r.read(b.center.z) && r.read(b.radius);
}

} // namespace mirage::lod::detail
