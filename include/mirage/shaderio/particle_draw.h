// Particle billboards (src/render/particle_draw.cpp, shaders/particle_billboard.*): what the draw
// pushes, written once for C++ and GLSL.
#ifndef MIRAGE_SHADERIO_PARTICLE_DRAW_H
#define MIRAGE_SHADERIO_PARTICLE_DRAW_H

#ifdef __cplusplus
#include <cstdint>
namespace mirage::shaderio {
using uint = uint32_t;
#endif

// ParticleDrawPush::flags
#define MIRAGE_PARTICLE_ALPHA_FROM_GREY 1u

struct ParticleDrawPush {
  uint64_t frameAddress;  // FrameData (shaderio/forward.h) of the eye
  uint64_t recordAddress; // RenderParticle[] (shaderio/particles.h)
  uint64_t oitAddress;    // OitLists (shaderio/oit.h) in linked-list mode, else 0
  uint sheet;             // index into the sheet array
  uint tilesX;
  uint tilesY;
  uint flags; // MIRAGE_PARTICLE_*
};

#ifdef __cplusplus
static_assert(sizeof(ParticleDrawPush) == 40, "ParticleDrawPush layout");
} // namespace mirage::shaderio
#endif

#endif
