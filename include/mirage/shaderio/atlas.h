// Shading Atlas Streaming (docs/stream.md): how a patch of 1-3 triangles lies in its atlas block,
// written once for the server's shading stage (GLSL), the CPU patch builder and atlas allocator,
// and the clients (native GLSL, browser JavaScript mirrors it: web/atlas.js), so every side puts
// the same surface point on the same texel.
//
// A block is 2^log2 texels high and as wide (1-2 triangles) or twice as wide (3 triangles).
// The patch's vertices a..e sit on texel centres of the block's corners, in units of the block
// height h (corner coordinates):
//
//   c (0,1) ---- d (1,1)
//     |  t0 /  t1  | \  t2
//     |   /        |    \    (t2: wide blocks only)
//   a (0,0) ---- b (1,0) ---- e (2,0)
//
//   t0 = (a, b, c), t1 = (c, b, d), t2 = (b, e, d): t1 shares edge b-c with t0 and b-d with t2.
// A corner (cx, cy) maps to the texel position (0.5 + cx * (h - 1), 0.5 + cy * (h - 1)) inside
// the block, except e, at (2h - 0.5, 0.5) (the wide block's last texel centre). Every point of a
// triangle then samples (bilinearly) only texels of its own block, so blocks need no gutter.
// Texel (i, j) of the block is shaded as t2 when i >= h (wide blocks), else as t0 when
// i + j <= h - 1, else as t1; a texel outside its triangle extrapolates that triangle's
// attributes, so bilinear taps across a shared edge blend continuous values.
#ifndef MIRAGE_SHADERIO_ATLAS_H
#define MIRAGE_SHADERIO_ATLAS_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using uint = uint32_t;
using vec2 = glm::vec2;
using uvec2 = glm::uvec2;
#define MIRAGE_ATLAS_SHARED inline
#else
#define MIRAGE_ATLAS_SHARED
#endif

#define MIRAGE_ATLAS_MAX_PATCH_TRIANGLES 3
#define MIRAGE_ATLAS_MAX_PATCH_VERTICES 5
// Smallest block: 2 x 2 texels (a 1-texel block is a single colour: a colour message instead).
#define MIRAGE_ATLAS_MIN_BLOCK_LOG2 1
// Largest block and the superblock side: 128 texels.
#define MIRAGE_ATLAS_MAX_BLOCK_LOG2 7

// Vertex slots of a patch.
#define MIRAGE_PATCH_A 0
#define MIRAGE_PATCH_B 1
#define MIRAGE_PATCH_C 2
#define MIRAGE_PATCH_D 3
#define MIRAGE_PATCH_E 4

// A patch the shading stage shades (one per block written this frame).
struct GpuAtlasPatch {
  uint vertices[MIRAGE_ATLAS_MAX_PATCH_VERTICES]; // a..e: the scene's merged vertex indices (unused: = a)
  uint instance;                                  // object-to-world transform (GpuInstance)
  uint material;                                  // GpuMaterial index
  uint triangleCount;                             // 1..3 (3: a wide block)
  uint blockX, blockY;                            // the block's first texel in the atlas
  uint blockLog2;                                 // block height 2^blockLog2 texels
  uint pad0;
};

// Block width in texels: twice the height for 3-triangle patches.
MIRAGE_ATLAS_SHARED uint atlasBlockWidth(uint triangleCount, uint blockLog2) {
  return (triangleCount == 3u ? 2u : 1u) << blockLog2;
}

// Texel position (texel units, texel centres at .5) of vertex slot `v` (MIRAGE_PATCH_*) inside a
// block of height 2^blockLog2.
MIRAGE_ATLAS_SHARED vec2 atlasCornerTexel(uint v, uint blockLog2) {
  float h = float(1u << blockLog2);
  float far = h - 0.5f;
  if (v == MIRAGE_PATCH_B) return vec2(far, 0.5f);
  if (v == MIRAGE_PATCH_C) return vec2(0.5f, far);
  if (v == MIRAGE_PATCH_D) return vec2(far, far);
  if (v == MIRAGE_PATCH_E) return vec2(2.0f * h - 0.5f, 0.5f);
  return vec2(0.5f, 0.5f);
}

// Vertex slots of triangle t (0..2) of a patch, in winding order of the source triangle.
MIRAGE_ATLAS_SHARED uint atlasTriangleVertex(uint t, uint corner) {
  // t0 = (a, b, c), t1 = (c, b, d), t2 = (b, e, d)
  uint packed = t == 0u ? 0x210u : (t == 1u ? 0x312u : 0x341u);
  return (packed >> (4u * corner)) & 0xfu;
}

// The triangle of the patch that texel (i, j) of its block is shaded as.
MIRAGE_ATLAS_SHARED uint atlasTexelTriangle(uvec2 texel, uint triangleCount, uint blockLog2) {
  uint h = 1u << blockLog2;
  if (triangleCount == 3u && texel.x >= h) return 2u;
  if (texel.x + texel.y <= h - 1u || triangleCount == 1u) return 0u;
  return 1u;
}

// A streamed particle look's block (docs/stream.md, "Particles"): wide, 2h x h texels (h =
// 2^blockLog2), holding its sheet tile's mip chain: level k, (h >> k) texels a side, at
// atlasParticleLevelOffset (level 0 at the block's left, levels 1, 2, ... side by side right of it,
// on the top row). Each level holds the tile edge to edge: its texel (i, j) is the tile's average
// over [i / s, (i + 1) / s) x [j / s, (j + 1) / s) of its uv ((0, 0) at the tile's top left), s the
// level's side, a box filter's mip. A point of the tile samples level k at atlasParticleLevelTexel:
// clamped to the level's outer texel centres, so a bilinear tap never leaves the level (the outer
// half texel repeats the edge texel) and blocks need no gutter. A client picks the level from the
// footprint of its pixel on the tile, as a mipmapped texture fetch does: particles of one look far
// smaller on screen than the one its block was sized for read the coarser levels instead of
// aliasing the finest.
MIRAGE_ATLAS_SHARED uint atlasParticleLevelOffset(uint level, uint blockLog2) {
  uint h = 1u << blockLog2;
  return level == 0u ? 0u : 2u * h - (h >> (level - 1u));
}

// Texel position (texel units, texel centres at .5) inside the block of tile point `tileUv` in
// level `level` (0..blockLog2).
MIRAGE_ATLAS_SHARED vec2 atlasParticleLevelTexel(vec2 tileUv, uint blockLog2, uint level) {
  float s = float((1u << blockLog2) >> level);
  vec2 t = tileUv * s;
  t.x = t.x < 0.5f ? 0.5f : (t.x > s - 0.5f ? s - 0.5f : t.x);
  t.y = t.y < 0.5f ? 0.5f : (t.y > s - 0.5f ? s - 0.5f : t.y);
  return vec2(float(atlasParticleLevelOffset(level, blockLog2)) + t.x, t.y);
}

#ifdef __cplusplus
static_assert(sizeof(GpuAtlasPatch) == 48);
} // namespace mirage::shaderio
#endif
#endif
