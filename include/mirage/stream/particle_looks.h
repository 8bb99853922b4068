#pragma once
// Streamed particles, the server's CPU side (docs/stream.md, "Particles"; seed 004 ch. 5.4.3): the
// looks an effect's particles can have and their pre-shaded atlas texels, which particles a view
// sees and how large, and which visible particle gets a look's atlas block. No Vulkan.
//
// A particle's look is its system's sheet tile of its frame: every particle showing the same tile
// shows the same texture, tinted by its own colour. With texture merging one block per look serves
// every particle of that look (its master, the one largest on screen, sizes the block); without
// it every visible particle has a block of its own (the seed's naive approach).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/particles/effect.h"
#include "mirage/particles/sheet.h"
#include "mirage/shaderio/particles.h"
#include "mirage/stream/atlas.h"

namespace mirage::stream {

// How particles get atlas blocks: one per look (texture merging, the default) or one per visible
// particle (the baseline).
enum class ParticlePatches { Merged, Each };
inline constexpr EnumName<ParticlePatches> kParticlePatchesNames[] = {{ParticlePatches::Merged, "merged"},
                                                                      {ParticlePatches::Each, "each"}};

// Largest block of a particle look: a sheet tile has kSheetTilePixels texels a side, so a larger
// block would hold no detail the texture has (and cost four times the texels a level).
inline constexpr uint32_t kParticleMaxBlockLog2 = 5;
static_assert((1u << kParticleMaxBlockLog2) == particles::kSheetTilePixels, "a look's largest block is its tile");

// The looks of an effect: every tile of every system's sheet, systems with the same generated sheet
// and alpha rule sharing theirs. Particles are unlit (the renderers draw sheet texel x particle
// colour), so a look is shaded once, at load: its tile's box-filtered mips as the factor the client
// multiplies a particle's colour by (the texel, or with alpha_from_greyscale white with the
// texel's luminance as alpha); a block holds the mip chain from its level down (shaderio/atlas.h,
// atlasParticleLevelOffset).
class ParticleLooks {
public:
  // Errors: a sheet that does not generate (names the effect and system).
  static Result<ParticleLooks> build(const particles::EffectFile& effect);

  uint32_t lookCount() const { return uint32_t(texelOffset_.size()); }
  uint32_t systemCount() const { return uint32_t(systemFirst_.size()); }
  // The look of system `system`'s sheet frame `frame` (wrapped over the sheet's tiles, as the
  // renderers wrap it).
  uint32_t look(uint32_t system, uint32_t frame) const;
  // The look's block at level log2 (0..kParticleMaxBlockLog2): 2^log2 x 2^log2 RGBA8, rows from the
  // tile's top, sRGB-encoded rgb and linear alpha as the atlas holds them.
  std::span<const uint8_t> texels(uint32_t look, uint32_t log2) const;
  // The look's one colour (level 0, the tile's average): what a particle of a look without a block
  // is drawn with.
  std::array<uint8_t, 4> colour(uint32_t look) const;
  // The look's mip chain written into `block` (wide, log2 in MIRAGE_ATLAS_MIN_BLOCK_LOG2..
  // kParticleMaxBlockLog2, inside `atlas`): levels 0..log2 of the block, 2^(log2 - k) texels a
  // side. Returns the texels written (4/3 of level 0's, less a third of a texel).
  uint64_t write(uint32_t look, const AtlasPlacement& block, ImageRGBA8& atlas) const;

private:
  std::vector<uint32_t> systemFirst_, systemTiles_; // per system: its sheet's first look, tile count
  std::vector<size_t> texelOffset_;                 // per look: its levels 0..max, concatenated
  std::vector<uint8_t> texels_;
};

// A view as particle culling and level selection see it.
struct ParticleView {
  glm::mat4 view{1.0f}, proj{1.0f};
  float viewportHeight = 1.0f;
};

// A visible particle: its index among the records and its billboard's edge in pixels, the largest
// over the views that see it.
struct VisibleParticle {
  uint32_t record = 0;
  float pixels = 0.0f;
};

// The records whose billboard a view may show: the centre in front of the eye (a billboard lies in
// the view plane at its centre's depth) and the billboard's circumscribed sphere, grown as the
// client grows sub-pixel billboards (particleGrow), not outside a side plane of the frustum. The
// far plane is left to the client's clip planes. In record order.
std::vector<VisibleParticle> visibleParticles(std::span<const shaderio::RenderParticle> records,
                                              std::span<const ParticleView> views);

// The edge in pixels beyond which a look's block would pass kParticleMaxBlockLog2 at `bias`
// (blockLog2ForLength): level fitting counts a particle block at most this long.
float particleCapLength(float bias);
// A look's block level for a billboard edge of `pixels`: blockLog2ForLength of a square block
// (the mip chain beside it makes the block wide), capped at kParticleMaxBlockLog2.
uint32_t particleBlockLog2(float pixels, float bias);

} // namespace mirage::stream
