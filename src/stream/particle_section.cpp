// A Frame's particle section (patch_section.h; docs/stream.md, "Particle section"): the looks whose
// block changed, as the patch section's entries (ids as gaps, blocks in block units), then every
// visible particle in columns (looks, x, y, z, sizes, rotations, colours), each column a run of
// like values that zstd finds more to share in than in interleaved records. The decoder checks
// each count against its limit and the bytes left before it sizes a vector, every block against
// the atlas side, every size for a finite non-negative half, and that every look sent is used.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>

#include <glm/gtc/packing.hpp>

#include "mirage/shaderio/atlas.h"
#include "patch_section.h"

namespace mirage::stream {

namespace wire {

namespace {

// Smallest entries in the raw section: a look with a block (id gap, log2, x, y); a particle (look,
// three u16 coordinates, size, rotation, rgba).
constexpr size_t kLookMinBytes = 4;
constexpr size_t kParticleBytesMin = 1 + 6 + 2 + 2 + 4;

std::vector<uint8_t> rawParticleSection(const Frame& frame) {
  Writer w;
  w.out.reserve(8 + frame.looks.size() * 6 + frame.particles.size() * kParticleBytesMin);
  w.varint(uint32_t(frame.looks.size()));
  uint64_t next = 0;
  for (const ParticleLook& l : frame.looks) {
    assert(l.id >= next);
    w.varint(uint32_t(l.id - next));
    next = uint64_t(l.id) + 1;
    w.u8(l.blockLog2);
    if (l.blockLog2 == kColourOnlyBlock) {
      for (uint8_t c : l.rgba) w.u8(c);
      continue;
    }
    assert(l.blockX % (1u << l.blockLog2) == 0 && l.blockY % (1u << l.blockLog2) == 0);
    w.varint(uint32_t(l.blockX) >> l.blockLog2);
    w.varint(uint32_t(l.blockY) >> l.blockLog2);
  }
  w.varint(uint32_t(frame.particles.size()));
  if (frame.particles.empty()) return std::move(w.out);
  w.vec3(frame.particleOrigin);
  w.f32(frame.particleStep);
  for (const StreamParticle& p : frame.particles) w.varint(p.look);
  for (int k = 0; k < 3; ++k)
    for (const StreamParticle& p : frame.particles) w.u16(p.position[size_t(k)]);
  for (const StreamParticle& p : frame.particles) w.u16(p.size);
  for (const StreamParticle& p : frame.particles) w.u16(p.rotation);
  for (const StreamParticle& p : frame.particles)
    for (uint8_t c : p.rgba) w.u8(c);
  return std::move(w.out);
}

bool readLook(Reader& r, ParticleLook& l, uint64_t& next, const DecodeLimits& limits) {
  uint32_t gap = 0;
  if (!r.varint(gap, "id")) return false;
  if (next + gap > 0xffffffffull) return r.fail("id", "past 2^32 - 1");
  l.id = uint32_t(next + gap);
  next = uint64_t(l.id) + 1;
  if (!r.u8(l.blockLog2, "blockLog2")) return false;
  if (l.blockLog2 == kColourOnlyBlock) {
    for (uint8_t& c : l.rgba)
      if (!r.u8(c, "rgba")) return false;
    return true;
  }
  if (l.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || l.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
    return r.fail("blockLog2", std::to_string(l.blockLog2) + " not in 1..7 or 255 (colour-only)");
  uint32_t bx = 0, by = 0;
  if (!r.varint(bx, "blockX") || !r.varint(by, "blockY")) return false;
  uint64_t x = uint64_t(bx) << l.blockLog2, y = uint64_t(by) << l.blockLog2, side = 1u << l.blockLog2;
  if (x + 2 * side > limits.maxAtlasSide || y + side > limits.maxAtlasSide) // wide: level 0 and its mips
    return r.fail("blockX", "block at (" + std::to_string(x) + ", " + std::to_string(y) + ") size " +
                                std::to_string(2 * side) + "x" + std::to_string(side) + " outside the atlas side " +
                                std::to_string(limits.maxAtlasSide));
  l.blockX = uint16_t(x);
  l.blockY = uint16_t(y);
  return true;
}

bool readParticles(Reader& r, Frame& m, const DecodeLimits& limits) {
  uint32_t n = 0;
  if (!r.varintCount(n, limits.maxLooksPerFrame, kLookMinBytes, "looks count")) return false;
  m.looks.resize(n);
  uint64_t next = 0;
  for (uint32_t i = 0; i < n; ++i)
    if (!readLook(r, m.looks[i], next, limits)) {
      r.error = "looks[" + std::to_string(i) + "]." + r.error;
      return false;
    }
  if (!r.varintCount(n, limits.maxParticlesPerFrame, kParticleBytesMin, "particles count")) return false;
  if (n > 0) {
    if (!r.vec3(m.particleOrigin, "particles.origin") || !r.f32(m.particleStep, "particles.step")) return false;
    if (!(m.particleStep > 0.0f)) return r.fail("particles.step", std::to_string(m.particleStep) + " not above 0");
    if (!r.checkCount(n, limits.maxParticlesPerFrame, kParticleBytesMin, "particles count")) return false;
  }
  m.particles.resize(n);
  auto field = [](const char* what, uint32_t i) { return "particles[" + std::to_string(i) + "]." + what; };
  for (uint32_t i = 0; i < n; ++i)
    if (!r.varint(m.particles[i].look, field("look", i))) return false;
  for (size_t k = 0; k < 3; ++k)
    for (uint32_t i = 0; i < n; ++i)
      if (!r.u16(m.particles[i].position[k], field("position", i))) return false;
  for (uint32_t i = 0; i < n; ++i) {
    uint16_t& size = m.particles[i].size;
    if (!r.u16(size, field("size", i))) return false;
    if ((size & 0x8000u) != 0 || (size & 0x7c00u) == 0x7c00u)
      return r.fail(field("size", i), "not a finite non-negative half");
  }
  for (uint32_t i = 0; i < n; ++i)
    if (!r.u16(m.particles[i].rotation, field("rotation", i))) return false;
  for (uint32_t i = 0; i < n; ++i)
    for (uint8_t& c : m.particles[i].rgba)
      if (!r.u8(c, field("rgba", i))) return false;
  // Every look sent is one a particle of this frame uses (the section has one encoding).
  std::vector<uint8_t> used(m.looks.size(), 0);
  for (const StreamParticle& p : m.particles) {
    auto it = std::lower_bound(m.looks.begin(), m.looks.end(), p.look,
                               [](const ParticleLook& l, uint32_t id) { return l.id < id; });
    if (it != m.looks.end() && it->id == p.look) used[size_t(it - m.looks.begin())] = 1;
  }
  for (size_t i = 0; i < used.size(); ++i)
    if (!used[i])
      return r.fail("looks[" + std::to_string(i) + "]",
                    "look " + std::to_string(m.looks[i].id) + " is used by no particle of the frame");
  if (r.left() != 0) return r.fail("particles", std::to_string(r.left()) + " bytes after the colours");
  return true;
}

} // namespace

void writeParticleSection(Writer& w, const Frame& frame) {
  writeSection(w, frame.particleCodec, rawParticleSection(frame));
}

bool readParticleSection(Reader& r, Frame& frame, const DecodeLimits& limits) {
  std::vector<uint8_t> storage;
  std::span<const uint8_t> content;
  if (!readSectionContent(r, "particles", frame.particleCodec, storage, content, limits)) return false;
  Reader section(content);
  if (readParticles(section, frame, limits)) return true;
  r.error = section.error;
  return false;
}

} // namespace wire

size_t particleSectionBytes(const Frame& frame) {
  return wire::sectionBytes(frame.particleCodec, wire::rawParticleSection(frame));
}

float particleGridStep(const glm::vec3& min, const glm::vec3& max) {
  glm::vec3 extent = max - min;
  double largest = std::max({double(extent.x), double(extent.y), double(extent.z)});
  if (!(largest > 0.0)) return 1.0f; // one point: any step holds it
  // Rounded up so that kParticleGridMax steps reach the far side despite float rounding.
  float step = float(largest / kParticleGridMax);
  while (double(step) * kParticleGridMax < largest) step = std::nextafter(step, INFINITY);
  return step;
}

StreamParticle quantizeParticle(const glm::vec3& position, float size, float rotation, uint32_t rgba, uint32_t look,
                                const glm::vec3& origin, float step) {
  StreamParticle p;
  p.look = look;
  for (int k = 0; k < 3; ++k) {
    double q = std::nearbyint((double(position[k]) - double(origin[k])) / double(step));
    p.position[size_t(k)] = uint16_t(std::clamp(q, 0.0, double(kParticleGridMax)));
  }
  uint16_t half = glm::packHalf1x16(std::isfinite(size) ? std::clamp(size, 0.0f, 65504.0f) : 0.0f);
  p.size = half & 0x8000u ? 0 : half; // -0 as 0
  double turns = double(rotation) / (2.0 * std::numbers::pi);
  turns -= std::floor(turns);
  p.rotation = uint16_t(uint32_t(std::lround(turns * 65536.0)) & 0xffffu);
  for (int c = 0; c < 4; ++c) p.rgba[size_t(c)] = uint8_t(rgba >> (8 * c));
  return p;
}

glm::vec3 particlePosition(const StreamParticle& p, const glm::vec3& origin, float step) {
  return origin + glm::vec3(float(p.position[0]), float(p.position[1]), float(p.position[2])) * step;
}

float particleSize(uint16_t size) { return glm::unpackHalf1x16(size); }

float particleRotation(uint16_t rotation) { return float(double(rotation) * (2.0 * std::numbers::pi / 65536.0)); }

} // namespace mirage::stream
