#pragma once
// One client's particles on the server (docs/stream.md, "Particles"): the effect's CPU simulation,
// stepped to the connection's frame number (frame n shows the effect after n steps of
// kStreamParticleStep, as `mirage render --particles FX --particle-frames n`), the particles the
// client's views see, the atlas blocks of their looks (one per look with texture merging, one per
// particle without), and what the client holds of the looks. ClientStream (session.h) runs it
// inside each frame:
//   prepare (simulate, cull, masters) -> requests (with the patches' into the atlas allocator) ->
//   shade (the looks' texels copied into the GPU atlas before its read-back) -> diff (the Frame's particle section).
#include <cstdint>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/particles/simulation.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/stream/atlas.h"
#include "mirage/stream/particle_looks.h"
#include "mirage/stream/patches.h"
#include "mirage/stream/protocol.h"

namespace mirage::stream {

// Seconds of one simulation step: one per Frame of a connection.
inline constexpr float kStreamParticleStep = 1.0f / 60.0f;

// What a frame's particles cost (StreamFrameStats).
struct ParticleFrameStats {
  uint32_t visible = 0;    // particles in a view's frustum
  uint32_t looks = 0;      // looks used: blocks asked for (merged: one per look; each: one per particle)
  uint32_t colourOnly = 0; // of them without a block (atlas full): drawn in the look's colour
  uint64_t texels = 0;     // atlas texels shaded for particles (the blocks of the looks used)
};

class ClientParticles {
public:
  ClientParticles(const particles::EffectFile& effect, ParticlePatches mode);

  // The simulation stepped until it has taken `frame` steps (never back: a frame that failed and is
  // produced again is not stepped twice); the particles `views` see; the looks they use, each with
  // the billboard edge in pixels its block is sized for (merged: the largest of the look's
  // particles, its master; each: the particle's own).
  void prepare(const ParticleLooks& looks, uint32_t frame, std::span<const ParticleView> views);
  // The used looks as atlas requests (ids firstId + look; wide blocks, level 0 up to
  // kParticleMaxBlockLog2 and its mip chain beside it) and as extents for level fitting.
  void appendRequests(uint32_t firstId, float bias, std::vector<AtlasRequest>& requests) const;
  void appendExtents(float bias, std::vector<PatchExtent>& extents) const;
  // After the allocator's update: every used look's texels written into the GPU atlas at its block
  // (before the atlas is read back). Errors: the upload's.
  Status shade(const ParticleLooks& looks, const AtlasAllocator& allocator, uint32_t firstId,
               render::AtlasShading& shading, ParticleFrameStats& stats) const;
  // The Frame's particle section: the used looks whose block (or colour) the client does not hold,
  // every visible particle. Then what the client holds becomes the used looks (the last step of a
  // frame: nothing after it fails).
  void diff(const ParticleLooks& looks, const AtlasAllocator& allocator, uint32_t firstId, Frame& frame);

  // This frame's render records (tests and benchmarks), and the steps taken.
  const std::vector<shaderio::RenderParticle>& records() const { return records_; }
  uint32_t steps() const { return steps_; }

private:
  struct Used {
    uint32_t id;      // the look id on the wire (merged: the look; each: a particle's slot)
    uint32_t texture; // the look whose texels fill the block
    float pixels;     // the block is sized for this billboard edge
  };
  // What the client holds of a look: its block, or its colour.
  struct Held {
    std::optional<AtlasPlacement> block;
    std::array<uint8_t, 4> colour{};
    bool operator==(const Held&) const = default;
  };
  Held current(const ParticleLooks& looks, const AtlasAllocator& allocator, uint32_t firstId, const Used& u) const;

  ParticlePatches mode_;
  particles::Simulation sim_;
  uint32_t steps_ = 0;
  std::vector<shaderio::RenderParticle> records_;
  std::vector<uint32_t> systemOf_; // per record
  std::vector<VisibleParticle> visible_;
  std::vector<uint32_t> visibleLook_; // per visible particle: its wire look id
  std::vector<Used> used_;            // ascending id
  // Without merging: a slot per visible particle ((system << 32) | spawn index), reused once the
  // particle is out of view.
  std::unordered_map<uint64_t, uint32_t> slotOf_;
  std::vector<uint32_t> freeSlots_;
  uint32_t slotCount_ = 0;
  std::unordered_map<uint32_t, Held> held_; // the client's looks (after the last frame)
};

} // namespace mirage::stream
