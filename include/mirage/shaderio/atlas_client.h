// The thin client's renderer (render/atlas_client.h, docs/stream.md, "The client's renderer"): one record per patch
// slot, which the vertex shader expands into the patch's triangles (atlasTriangleVertex) and atlas
// uvs (atlasCornerTexel), both from shaderio/atlas.h. Written once for C++ and GLSL (scalar layout).
#ifndef MIRAGE_SHADERIO_ATLAS_CLIENT_H
#define MIRAGE_SHADERIO_ATLAS_CLIENT_H

#include "mirage/shaderio/atlas.h"
#include "mirage/shaderio/view.h"

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using uint = uint32_t;
using vec3 = glm::vec3;
#endif

// Vertices a slot expands to: every triangle a patch may have, three corners each (no index buffer;
// the triangles a patch lacks collapse to a point).
#define MIRAGE_CLIENT_SLOT_VERTICES (3 * MIRAGE_ATLAS_MAX_PATCH_TRIANGLES)

// GpuClientPatch::flags: the alpha mode (MIRAGE_ALPHA_* of shaderio/forward.h) in the low bits, and
// whether the patch is one colour (no block).
#define MIRAGE_CLIENT_ALPHA_MASK 3u
#define MIRAGE_CLIENT_COLOR_ONLY 4u

// One patch slot.
struct GpuClientPatch {
  vec3 positions[MIRAGE_ATLAS_MAX_PATCH_VERTICES]; // world positions of slots a..e (unused: = a)
  uint triangleCount;                              // 1..3; 0: an empty slot (draws nothing)
  uint flags;                                      // alpha mode | MIRAGE_CLIENT_COLOR_ONLY
  uint blockX, blockY;                             // the block's first texel in the atlas
  uint blockLog2;
  uint color; // colour-only patches: RGBA8, sRGB rgb (as the atlas texels), linear alpha
};

// A streamed particle (docs/stream.md, "Particles"): a camera-facing billboard (particle_quad.glsl)
// textured from its look's block (atlasParticleLevelTexel: the mip level its pixel's footprint picks)
// times its colour.
struct GpuClientParticle {
  vec3 position;  // world space, the billboard's centre
  float size;     // the billboard's edge, world units
  float rotation; // radians about the view axis
  uint color;     // the particle's colour: RGBA8, r in the low byte, linear, straight alpha
  uint block;     // the look's block, x | y << 16 (texels); blockLog2 0: the look's colour (RGBA8, sRGB rgb)
  uint blockLog2; // 1..7, or 0: no block (the look is one colour)
};

// Push constants of the client's draws.
struct AtlasClientPush {
  uint64_t frameAddress; // ViewFrame
  uint64_t patchAddress; // GpuClientPatch[slots]; the particle draw: GpuClientParticle[instances]
  uint64_t oitAddress;   // OitLists (shaderio/oit.h) of the blend pass, else 0
  vec2 atlasSize;        // texels (uv = texel position / atlasSize)
  uint alphaModes;       // bit (1 << MIRAGE_ALPHA_*) per mode this draw rasterizes
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(GpuClientPatch) == 84, "GpuClientPatch layout");
static_assert(sizeof(GpuClientParticle) == 32, "GpuClientParticle layout");
static_assert(sizeof(AtlasClientPush) == 40, "AtlasClientPush layout");
} // namespace mirage::shaderio
#endif

#endif
