// Streamed particles, the server's CPU side (particle_looks.h; docs/stream.md, "Particles").
#include "mirage/stream/particle_looks.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

#include <fmt/format.h>

#include "mirage/core/color.h"
#include "mirage/stream/patches.h"

namespace mirage::stream {

namespace {

constexpr uint32_t kTile = particles::kSheetTilePixels;

// Texels of levels 0..kParticleMaxBlockLog2 of one look.
constexpr size_t levelOffset(uint32_t log2) { return ((size_t(1) << (2 * log2)) - 1) / 3 * 4; }
constexpr size_t kLookBytes = levelOffset(kParticleMaxBlockLog2 + 1);

// One look's levels: the tile at (x0, y0) of `sheet` box-filtered to 2^k texels a side, as the
// factor the client multiplies the particle's colour by.
void shadeLook(const ImageRGBA8& sheet, uint32_t x0, uint32_t y0, bool alphaFromGreyscale, uint8_t* out) {
  for (uint32_t k = 0; k <= kParticleMaxBlockLog2; ++k) {
    uint32_t h = 1u << k, span = kTile / h;
    uint8_t* level = out + levelOffset(k);
    for (uint32_t j = 0; j < h; ++j)
      for (uint32_t i = 0; i < h; ++i) {
        double sum[4] = {0, 0, 0, 0};
        for (uint32_t y = 0; y < span; ++y)
          for (uint32_t x = 0; x < span; ++x) {
            const uint8_t* p = sheet.at(x0 + i * span + x, y0 + j * span + y);
            for (int c = 0; c < 4; ++c) sum[c] += p[c];
          }
        double n = 255.0 * span * span;
        glm::vec4 t(float(sum[0] / n), float(sum[1] / n), float(sum[2] / n), float(sum[3] / n));
        // The renderers' colour rule (particleShade): the coverage is the luminance, or the alpha.
        if (alphaFromGreyscale) t = glm::vec4(1.0f, 1.0f, 1.0f, glm::dot(glm::vec3(t), {0.2126f, 0.7152f, 0.0722f}));
        uint8_t* o = level + (size_t(j) * h + i) * 4;
        for (int c = 0; c < 3; ++c) o[c] = linearToSrgb8(t[c]);
        o[3] = uint8_t(std::lround(std::clamp(t.a, 0.0f, 1.0f) * 255.0f));
      }
  }
}

// A frustum side plane (xyz normalized) of viewProj: row 3 +- row `axis`.
glm::vec4 sidePlane(const glm::mat4& m, int axis, float sign) {
  glm::vec4 p(m[0][3] + sign * m[0][axis], m[1][3] + sign * m[1][axis], m[2][3] + sign * m[2][axis],
              m[3][3] + sign * m[3][axis]);
  float n = glm::length(glm::vec3(p));
  return n > 0.0f ? p / n : p;
}

} // namespace

Result<ParticleLooks> ParticleLooks::build(const particles::EffectFile& effect) {
  ParticleLooks looks;
  // Systems with the same sheet (texture and tiles) and alpha rule share their looks.
  std::map<std::tuple<std::string, uint32_t, uint32_t, bool>, uint32_t> firstOf;
  for (const particles::SystemDef& s : effect.systems) {
    auto key = std::make_tuple(s.sheet.texture, s.sheet.tilesX, s.sheet.tilesY, s.sheet.alphaFromGreyscale);
    uint32_t tiles = s.sheet.tilesX * s.sheet.tilesY;
    auto known = firstOf.find(key);
    if (known != firstOf.end()) {
      looks.systemFirst_.push_back(known->second);
      looks.systemTiles_.push_back(tiles);
      continue;
    }
    auto sheet = particles::systemSheet(s);
    if (!sheet) return makeError(effect.name, sheet.error().message);
    uint32_t first = looks.lookCount();
    firstOf.emplace(key, first);
    looks.systemFirst_.push_back(first);
    looks.systemTiles_.push_back(tiles);
    looks.texels_.resize(looks.texels_.size() + size_t(tiles) * kLookBytes);
    for (uint32_t f = 0; f < tiles; ++f) {
      looks.texelOffset_.push_back(size_t(first + f) * kLookBytes);
      shadeLook(*sheet, (f % s.sheet.tilesX) * kTile, (f / s.sheet.tilesX) * kTile, s.sheet.alphaFromGreyscale,
                looks.texels_.data() + looks.texelOffset_.back());
    }
  }
  return looks;
}

uint32_t ParticleLooks::look(uint32_t system, uint32_t frame) const {
  assert(system < systemFirst_.size());
  return systemFirst_[system] + frame % systemTiles_[system];
}

std::span<const uint8_t> ParticleLooks::texels(uint32_t look, uint32_t log2) const {
  assert(look < lookCount() && log2 <= kParticleMaxBlockLog2);
  return {texels_.data() + texelOffset_[look] + levelOffset(log2), size_t(4) << (2 * log2)};
}

std::array<uint8_t, 4> ParticleLooks::colour(uint32_t look) const {
  std::span<const uint8_t> t = texels(look, 0);
  return {t[0], t[1], t[2], t[3]};
}

uint64_t ParticleLooks::write(uint32_t look, const AtlasPlacement& block, ImageRGBA8& atlas) const {
  assert(block.wide && block.log2 >= MIRAGE_ATLAS_MIN_BLOCK_LOG2 && block.log2 <= kParticleMaxBlockLog2);
  assert(block.x + block.width() <= atlas.width && block.y + block.height() <= atlas.height);
  uint64_t written = 0;
  for (uint32_t k = 0; k <= block.log2; ++k) {
    const uint32_t side = block.height() >> k;
    std::span<const uint8_t> t = texels(look, block.log2 - k);
    uint32_t x = block.x + shaderio::atlasParticleLevelOffset(k, block.log2);
    for (uint32_t j = 0; j < side; ++j)
      std::memcpy(atlas.at(x, block.y + j), t.data() + size_t(j) * side * 4, size_t(side) * 4);
    written += uint64_t(side) * side;
  }
  return written;
}

std::vector<VisibleParticle> visibleParticles(std::span<const shaderio::RenderParticle> records,
                                              std::span<const ParticleView> views) {
  struct Frustum {
    glm::mat4 view;
    glm::vec4 planes[4];
    float proj11, viewportHeight;
  };
  std::vector<Frustum> frusta;
  for (const ParticleView& v : views) {
    glm::mat4 m = v.proj * v.view;
    frusta.push_back({v.view,
                      {sidePlane(m, 0, 1.0f), sidePlane(m, 0, -1.0f), sidePlane(m, 1, 1.0f), sidePlane(m, 1, -1.0f)},
                      v.proj[1][1],
                      v.viewportHeight});
  }
  std::vector<VisibleParticle> out;
  for (uint32_t i = 0; i < records.size(); ++i) {
    const shaderio::RenderParticle& r = records[i];
    float best = -1.0f;
    for (const Frustum& f : frusta) {
      float z = (f.view * glm::vec4(r.position, 1.0f)).z;
      if (!(z < 0.0f)) continue; // the billboard lies in the view plane at its centre's depth
      float pixels = shaderio::particleEdgePixels(f.proj11, f.viewportHeight, r.size, z);
      float radius = 0.5f * std::sqrt(2.0f) * r.size * shaderio::particleGrow(pixels);
      bool inside = true;
      for (const glm::vec4& p : f.planes) inside = inside && glm::dot(glm::vec3(p), r.position) + p.w >= -radius;
      if (inside) best = std::max(best, pixels);
    }
    if (best >= 0.0f) out.push_back({i, best});
  }
  return out;
}

float particleCapLength(float bias) { return float((1u << kParticleMaxBlockLog2) - 1) * std::exp2(-bias); }

uint32_t particleBlockLog2(float pixels, float bias) {
  return std::min(blockLog2ForLength(pixels, 2, bias), kParticleMaxBlockLog2);
}

} // namespace mirage::stream
