// The server's atlas stages (render/atlas_shading.h, docs/stream.md, "The server's GPU stages"): push constants and
// records shared by C++ and the shaders atlas_visibility.*, atlas_shade/atlas_colour.comp and atlas_yuv.comp.
// Scalar block layout through buffer device addresses, as shaderio/forward.h.
#ifndef MIRAGE_SHADERIO_ATLAS_SHADING_H
#define MIRAGE_SHADERIO_ATLAS_SHADING_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using uint = uint32_t;
using vec2 = glm::vec2;
using mat4 = glm::mat4;
#endif

// Threads of the shading workgroup: one 8 x 8 tile of a block, a thread per texel.
#define MIRAGE_ATLAS_TILE 8
// Threads of the colour-only workgroup: a thread per patch.
#define MIRAGE_ATLAS_COLOUR_GROUP 64

// Push constants of the visibility passes (depth prepass and marking; <= 128 bytes).
struct AtlasVisibilityPush {
  mat4 viewProj;
  uint64_t instanceAddress;      // GpuInstance[] in scene order
  uint64_t firstTriangleAddress; // uint[] per instance: its first global triangle id
  uint64_t patchOfTriangleAddress;
  uint64_t flagsAddress;    // uint[] per global patch: 1 once a marked fragment covered it
  uint64_t materialAddress; // GpuMaterial[] (the MASK prepass)
  uint materialIndex;
  uint pad0;
};

// The compute visibility (docs/stream.md, "Visibility stage"): the cluster renderer's compute
// raster draws the scene, cut into clusters of consecutive mesh triangles, into a 64-bit visibility
// buffer; marking rasters walk every cluster again and set the bits of the patches whose samples
// are not behind that nearest depth, less MIRAGE_ATLAS_DEPTH_TOLERANCE of it
// (atlas_visibility_mark*.comp). Visibility ids are the raster's ((list entry + 1) <<
// MIRAGE_CLUSTER_TRIANGLE_BITS | triangle): a list entry's triangle t is global triangle
// entryTriangle[entry] + t.
struct AtlasVisibilityTables {
  uint64_t entryTriangleAddress;   // uint[] per visible-list entry: the global id of its cluster's triangle 0
  uint64_t patchOfTriangleAddress; // uint[] per global triangle
  uint64_t patchBitsAddress;       // uint[]: bit p set once patch p is seen
};

// Share of the nearest (reverse-Z) depth a sample may lie behind it and still mark its patch: a
// surface meeting or coplanar with the nearest one within 0.05 % of the distance (5 cm at 100 m),
// where another rasterizer's rounding (the client's) may show it instead.
#define MIRAGE_ATLAS_DEPTH_TOLERANCE (1.0 / 2048.0)

// Depth tiles of the marking rasters: after the depth raster, each camera's farthest nearest depth
// per MIRAGE_ATLAS_DEPTH_TILE^2 pixels (the smallest reverse-Z value; 0 where a pixel saw nothing),
// stored as float bits after that camera's pixels in the 64-bit buffer (atlas_visibility_tiles.comp).
// A marking triangle whose nearest corner lies behind every tile its box touches, less the
// tolerance, has no sample that counts and is not walked (atlas_visibility_mark.glsl).
#define MIRAGE_ATLAS_DEPTH_TILE 8
// Boxes over this many tiles are walked without the test (the walk stops at its first counting sample).
#define MIRAGE_ATLAS_DEPTH_TILES_TESTED 16

struct AtlasDepthTilesPush {
  uint64_t visBufferAddress; // one camera's pixels (uint64_t each), its tiles (uint each) after them
  uint width;
  uint height;
};

// One 8 x 8 tile of a patch's block to shade.
struct AtlasTile {
  uint patchIndex; // into the shaded GpuAtlasPatch[]
  uint tile;       // x | y << 16, in tiles inside the block
};

// Push constants of atlas_shade.comp (one workgroup per AtlasTile).
struct AtlasShadePush {
  uint64_t frameAddress;    // FrameData: camera.eye and the lighting (the forward renderer's)
  uint64_t vertexAddress;   // GpuVertex[]: the scene's merged vertices (forward renderer order)
  uint64_t instanceAddress; // GpuInstance[] in scene order
  uint64_t materialAddress; // GpuMaterial[]
  uint64_t patchAddress;    // GpuAtlasPatch[]
  uint64_t tileAddress;     // AtlasTile[tileCount]
  uint tileCount;
  uint pad0;
};

// A colour-only patch: the point of one of its triangles where it is shaded (its centroid).
struct AtlasColourSample {
  uint vertices[3]; // merged vertex indices of the triangle, in winding order
  uint instance;
  uint material;
  float bary1, bary2; // barycentrics of the point w.r.t. vertices[1], vertices[2]
  uint pad0;
};

// Push constants of atlas_colour.comp (a thread per sample).
struct AtlasColourPush {
  uint64_t frameAddress;
  uint64_t vertexAddress;
  uint64_t instanceAddress;
  uint64_t materialAddress;
  uint64_t sampleAddress; // AtlasColourSample[count]
  uint64_t outputAddress; // uint[count]: RGBA8, sRGB-encoded colour, linear alpha
  uint count;
  uint pad0;
};

// The atlas as the H.264 encoder takes it (atlas_yuv.comp; docs/stream.md, "Codecs"): YUV 4:2:0,
// 8 bits a sample, full-range BT.709 of the atlas's sRGB-encoded bytes as they are (what libswscale
// makes of them: the CPU path, video.h's rgbaToI420, within 1 a sample). Luma per texel; chroma the
// mean of each 2 x 2 texel quad (swscale's area filter: blocks are >= 2 x 2 and aligned, so no
// chroma sample mixes two blocks). With stacked alpha the image is twice the atlas height, the
// alpha below the colour as grey: Y = alpha, U = V = 128.
// I420 layout, planes back to back, no padding: Y (side x height), U, V (side/2 x height/2).
// A thread converts MIRAGE_ATLAS_YUV_RUN texels of two rows: two luma runs and one chroma run of
// each plane, whole 32-bit words (the side is a multiple of 128).
#define MIRAGE_ATLAS_YUV_RUN 8
#define MIRAGE_ATLAS_YUV_GROUP 8 // workgroup: 8 x 8 threads
// BT.709 luma weights of R and B (G's is 1 - KR - KB); chroma (B - Y) / (2 (1 - KB)) + 128 and
// (R - Y) / (2 (1 - KR)) + 128, full range (no 16..235 scaling).
#define MIRAGE_BT709_KR 0.2126
#define MIRAGE_BT709_KB 0.0722

// Push constants of atlas_yuv.comp (a thread per 8 x 2 texels of the atlas).
struct AtlasYuvPush {
  uint64_t outputAddress; // uint[]: the I420 planes, atlasYuvBytes
  uint side;              // atlas side in texels
  uint stackedAlpha;      // 1: the image is 2 x side high, the alpha below the colour
};

#ifdef __cplusplus
#define MIRAGE_YUV_SHARED inline
#else
#define MIRAGE_YUV_SHARED
#endif
// Luma rows of the converted image.
MIRAGE_YUV_SHARED uint atlasYuvHeight(uint side, uint stackedAlpha) { return stackedAlpha != 0u ? 2u * side : side; }
// Byte offsets of the U and V planes.
MIRAGE_YUV_SHARED uint atlasYuvUOffset(uint side, uint stackedAlpha) {
  return side * atlasYuvHeight(side, stackedAlpha);
}
MIRAGE_YUV_SHARED uint atlasYuvVOffset(uint side, uint stackedAlpha) {
  return atlasYuvUOffset(side, stackedAlpha) + (side / 2u) * (atlasYuvHeight(side, stackedAlpha) / 2u);
}
// The image's bytes: 1.5 a luma sample.
MIRAGE_YUV_SHARED uint atlasYuvBytes(uint side, uint stackedAlpha) {
  return atlasYuvVOffset(side, stackedAlpha) + (side / 2u) * (atlasYuvHeight(side, stackedAlpha) / 2u);
}
#undef MIRAGE_YUV_SHARED

#ifdef __cplusplus
static_assert(sizeof(AtlasYuvPush) == 16, "AtlasYuvPush layout");
static_assert(sizeof(AtlasVisibilityPush) == 112, "AtlasVisibilityPush layout");
static_assert(sizeof(AtlasVisibilityTables) == 24, "AtlasVisibilityTables layout");
static_assert(sizeof(AtlasTile) == 8, "AtlasTile layout");
static_assert(sizeof(AtlasShadePush) == 56, "AtlasShadePush layout");
static_assert(sizeof(AtlasColourSample) == 32, "AtlasColourSample layout");
static_assert(sizeof(AtlasColourPush) == 56, "AtlasColourPush layout");
} // namespace mirage::shaderio
#endif
#endif
