// Structs shared by C++ and GLSL for the Blue Surfels sampler: written once, compiled by both.
// GLSL reads them with scalar block layout through buffer device addresses; the static_asserts
// keep the C++ sizes equal to what the shaders read.
#ifndef MIRAGE_SHADERIO_SURFELS_H
#define MIRAGE_SHADERIO_SURFELS_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using vec2 = glm::vec2;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using mat4 = glm::mat4;
using uint = uint32_t;
#endif

// Bits per axis of a quantized surfel position: 3 × 21 bits fill two words, and 2^21 steps over a
// model's box are far below a texel of the largest G-buffer (16384²).
#define MIRAGE_SURFEL_POSITION_BITS 21

// One output surfel, 16 bytes: what a renderer streams, so it is quantized. The radius is implied
// by the position in the progressive order (SurfelCloud::radii), never stored per surfel.
struct Surfel {
  uint posLo;  // x (21 bits) | low 11 bits of y << 21, quantized in the cloud's box
  uint posHi;  // high 10 bits of y | z (21 bits) << 10
  uint normal; // octahedral unit normal, two 16-bit snorm (x low, y high)
  uint color;  // linear RGBA8 base colour (R low)
};

// Vertex input of the G-buffer capture (36 bytes).
struct SurfelCaptureVertex {
  vec3 position;
  vec3 normal;
  uint color; // linear RGBA8 vertex colour, white when the mesh has none
  vec2 uv;    // base colour texture coordinate (0 when the mesh has none)
};

// One orthographic capture direction.
struct SurfelView {
  mat4 viewProj;  // world -> clip, depth 0 at the camera side of the bounding sphere
  vec4 direction; // xyz unit direction from the scene towards the camera, w unused
};

// Per instance of the capture: object-to-world and its normal matrix.
struct SurfelInstance {
  mat4 model;
  mat4 normalMatrix;
};

// Push constants of the capture pipeline (vertex and fragment stages).
struct SurfelCapturePush {
  uint64_t viewAddress;     // SurfelView[] (one per direction)
  uint64_t instanceAddress; // SurfelInstance[]
  uint64_t previousLayer;   // depth peeling: vec4 positions of the previous layer's V views; 0 on layer 0
  vec4 baseColor;           // material base colour factor (linear)
  uint baseView;            // first view of this multiview pass
  uint resolution;          // G-buffer width = height
  float peelEpsilon;        // a peeled surface lies at least this far behind the previous layer
  uint baseColorTexture;    // index into the capture's texture array; 0 is a white texel
};

// One scanner point of the GPU point-cloud capture (32 bytes): splatted as an oriented disc.
struct SurfelPoint {
  vec3 position; // world space
  float radius;  // disc radius (world): the point's 16th-neighbour distance, clamped (point_cloud.h)
  vec3 normal;   // unit normal (+z when the scan has none)
  uint color;    // linear RGBA8
};

// Push constants of the point-cloud capture passes (surfel_points_splat.comp, surfel_points_resolve.comp),
// one depth-peeling layer per splat + resolve.
struct SurfelPointPush {
  uint64_t points;        // SurfelPoint[pointCount]
  uint64_t views;         // SurfelView[viewCount] (the directions of one layer)
  uint64_t depthKeys;     // uint64[texelCount]: (depth bits << 32) | point, min wins; ~0 = empty
  uint64_t positions;     // vec4[texelCount] out (this layer's slice): the disc's plane point, w = 1 where hit
  uint64_t normals;       // uvec2[texelCount] out: half-float xyz0 (the mesh capture's RGBA16F layout)
  uint64_t colors;        // uint[texelCount] out: linear RGBA8
  uint64_t previousLayer; // depth peeling: vec4 positions of the previous layer's slice; 0 on layer 0
  vec4 center;            // xyz capture sphere centre, w its radius
  uint resolution;        // G-buffer width = height
  uint viewCount;         // views of one layer
  uint pointCount;
  uint cullBackFacing; // 1: discs facing away from a view are not splatted into it (oriented normals)
  float peelEpsilon;   // a peeled disc point lies at least this far behind the previous layer's
  uint pad0, pad1, pad2;
};

// Everything the sampler's compute passes share, in one small buffer (push constants stay small).
struct SurfelSamplerGlobals {
  uint64_t positions;  // vec4[texelCount]: world position, w = 1 where the texel saw the surface
  uint64_t cells;      // uint64[texelCount]: Voronoi cell = (distance bits << 32) | sample index, min wins
  uint64_t owners;     // uint64[texelCount]: Poisson disc owner = (radius bits << 32) | texel, max wins
  uint64_t samples;    // uint[capacity]: texel index of each sample, in progressive order
  uint64_t radii;      // float[capacity]: distance of each sample to the earlier ones when it was added
  uint64_t cellMax;    // uint64[capacity]: farthest texel per cell = (distance bits << 32) | texel
  uint64_t candidates; // uint64[capacity]: candidate keys, sorted descending
  uint64_t counters;   // SurfelSamplerCounters
  uint64_t views;      // SurfelView[viewCount]
  vec4 center;         // xyz centre of the capture sphere (first sample's reference point)
  uint resolution;     // G-buffer width = height
  uint viewCount;
  uint texelCount;    // viewCount * resolution²
  float texelSize;    // world size of one texel
  uint64_t depthCopy; // --disc-raster mesh-depth: float[texelCount], the Voronoi depth images' copy (distance·2^-shift)
  uint64_t idCopy;    // --disc-raster mesh-depth: uint[texelCount], the Voronoi id images' copy (~0: no sample)
};

// Counters the sampler reads back after each half-round.
struct SurfelSamplerCounters {
  uint maxDistance;    // float bits of the largest texel-to-nearest-sample distance (atomicMax)
  uint candidateCount; // candidates appended this round
  uint validCount;     // candidates that survived the Poisson-disc conflict test
  uint pad0;
};

// Push constants of the sampler's compute passes; fields are per pass (see the shaders).
struct SurfelSamplerPush {
  uint64_t globals;  // SurfelSamplerGlobals
  uint first;        // first sample / candidate / element of this dispatch
  uint count;        // number of samples / candidates / elements
  float radius;      // splat radius (world units); <= 0: whole view
  float threshold;   // candidate filter: keep radius >= threshold * round maximum
  uint tilesPerSide; // splat tiles per side of the disc's bounding square
  uint tileSpan;     // texels per side of one tile
  uint padTo;        // surfel_validate.comp: zero the keys in [count, padTo) (the bitonic sort's padding)
  uint depthShift;   // mesh-depth Voronoi: depth = distance · 2^-depthShift (int; exact, <= 0.5)
  uint mode;         // surfel_farthest.comp: 1 = first round (distance to the centre)
  uint pad0;
};

#ifndef __cplusplus
// GLSL views of the buffers above, reached through device addresses. Shaders enable
// GL_EXT_buffer_reference, GL_EXT_scalar_block_layout and GL_EXT_shader_explicit_arithmetic_types_int64
// before including this header.
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelViewRef { SurfelView v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelInstanceRef { SurfelInstance v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelPointRef { SurfelPoint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer SurfelU32x2Ref { uvec2 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer SurfelGlobalsRef { SurfelSamplerGlobals g; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelCountersRef { SurfelSamplerCounters c; };
layout(buffer_reference, scalar, buffer_reference_align = 16) buffer SurfelVec4Ref { vec4 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer SurfelU64Ref { uint64_t v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelU32Ref { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SurfelF32Ref { float v[]; };
#endif

#ifdef __cplusplus
static_assert(sizeof(Surfel) == 16, "Surfel layout");
static_assert(sizeof(SurfelCaptureVertex) == 36, "SurfelCaptureVertex layout");
static_assert(sizeof(SurfelView) == 80, "SurfelView layout");
static_assert(sizeof(SurfelInstance) == 128, "SurfelInstance layout");
static_assert(sizeof(SurfelCapturePush) == 56, "SurfelCapturePush layout");
static_assert(sizeof(SurfelPoint) == 32, "SurfelPoint layout");
static_assert(sizeof(SurfelPointPush) == 104, "SurfelPointPush layout");
static_assert(sizeof(SurfelSamplerGlobals) == 120, "SurfelSamplerGlobals layout");
static_assert(sizeof(SurfelSamplerCounters) == 16, "SurfelSamplerCounters layout");
static_assert(sizeof(SurfelSamplerPush) == 48, "SurfelSamplerPush layout");
} // namespace mirage::shaderio
#endif

#endif
