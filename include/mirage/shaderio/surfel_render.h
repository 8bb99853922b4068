// Structs shared by C++ and GLSL for the surfel renderer (docs/surfels.md, "Rendering"): written
// once, compiled by both. GLSL reads them with scalar block layout through buffer device addresses;
// the static_asserts keep the C++ sizes equal to what the shaders read.
#ifndef MIRAGE_SHADERIO_SURFEL_RENDER_H
#define MIRAGE_SHADERIO_SURFEL_RENDER_H

#include "mirage/shaderio/forward.h" // GpuMaterial, shared with the mesh renderers
#include "mirage/shaderio/surfels.h" // Surfel and its quantization (MIRAGE_SURFEL_POSITION_BITS)

#ifdef __cplusplus
namespace mirage::shaderio {
#endif

// Splat workgroup: a multiple of both subgroup sizes we meet (lavapipe 8, NVIDIA 32).
#define MIRAGE_SURFEL_SPLAT_WORKGROUP 256
// Surfels per splat thread (strided by the workgroup size, so every load instruction is coalesced):
// a batch of 1024 surfels per workgroup amortizes the per-workgroup instance lookup.
#define MIRAGE_SURFEL_PER_THREAD 4
#define MIRAGE_SURFEL_BATCH (MIRAGE_SURFEL_SPLAT_WORKGROUP * MIRAGE_SURFEL_PER_THREAD)
// Splat dispatches split the batches over x and y: x stays under the guaranteed 65535.
#define MIRAGE_SURFEL_DISPATCH_X 65535
// Workgroup of the per-instance prefix pass and of the one-workgroup scan.
#define MIRAGE_SURFEL_INSTANCE_WORKGROUP 256
// Largest splat radius in pixels: a surfel closer than the cloud's density supports (k clamped to
// N) would otherwise cover a large square per thread; the mesh takes over there (cross-fade).
#define MIRAGE_SURFEL_MAX_RADIUS_PX 8.0
// A surfel writes the pixel centres inside its disc plus the pixel holding its projection (the
// nearest centre, so a disc that holds any centre holds that one): under half a pixel that is the
// one pixel (the 1-pixel fast path, one atomic per surfel).
#define MIRAGE_SURFEL_FAST_RADIUS_PX 0.5

// SurfelRenderFrame::flags
#define MIRAGE_SURFEL_FRUSTUM_CULL 1u   // instances outside the view frustum get k = 0
#define MIRAGE_SURFEL_ALL 2u            // benchmark: every instance splats all N surfels (no prefix)
#define MIRAGE_SURFEL_SOURCE_BUFFER 4u  // the resolve reads the 64-bit buffer (compute splat), else the image
#define MIRAGE_SURFEL_MESH_FADE 8u      // a mesh pass draws near instances: fade surfels in over a band
#define MIRAGE_SURFEL_BACKFACE_CULL 16u // single-sided clouds skip surfels facing away from the eye
#define MIRAGE_SURFEL_MERGE_ALL 32u     // the merge splat pipeline: every instance takes the subgroup merge
#define MIRAGE_SURFEL_MERGE_AUTO 64u    // ... only dense instances (SurfelMerge::Auto, below)
#define MIRAGE_SURFEL_ORIENTED 128u     // discs lie in the surfel's tangent plane (ellipses on screen)

// Coherent splat order (docs/surfels.md, "Coherent order"): the renderer stores each cloud in
// blocks that keep the blue-noise prefix order between blocks and sort by Morton code within them.
// The block holding position i (i >= 1) has size max(minBlock, 2^floor(log2 i) >> SHIFT): minBlock
// surfels up to 2^SHIFT * minBlock, then 1/2^SHIFT of the position, so rounding a prefix up to its
// block's end adds at most 1/2^SHIFT (6.25 %) beyond minBlock. minBlock (per cloud,
// SurfelRenderCloud::coherentMinBlock) is a power of two >= 32, so block boundaries are multiples
// of the block size and every warp's 32 consecutive surfels lie in one block.
#define MIRAGE_SURFEL_COHERENT_BLOCK_SHIFT 4

// Back-face culling keeps surfels whose normal leans away from the eye by less than this cosine:
// capture normals are shading normals, which can face slightly away on silhouette triangles that
// still face the eye, and those surfels fill the rim (the hole-free test covers it).
#define MIRAGE_SURFEL_BACKFACE_COS 0.25

// Oriented discs (SurfelRenderSettings::orientedDiscs): a disc seen at angle θ projects to an
// ellipse whose minor radius R·|cos θ| is kept at least this many pixels, so a disc seen edge-on
// still writes its line of pixels (the role of EWA's low-pass filter).
#define MIRAGE_SURFEL_MIN_MINOR_PX 0.5
// ... and only discs of at least this radius are oriented: below, a disc's footprint is the pixel
// holding its centre and at most a few neighbours, which the ellipse would barely change, and the
// normal load (8 more bytes per surfel) is saved on the dense splats that dominate the cost.
#define MIRAGE_SURFEL_ORIENTED_MIN_RADIUS_PX 1.0

// SurfelMerge::Auto: an instance takes the subgroup merge when its surfels' disc radius at its
// nearest point is below this many pixels: then about 1 / (0.87 r^2) >= 4.6 surfels share a pixel,
// so a warp of 32 consecutive (coherent) surfels covers ~7 pixels and most of its atomics merge.
// Adaptive prefixes keep r near s / 2 (1 px by default) and never get there; instances whose
// whole cloud is drawn (k = N, far away, or every surfel in the benchmark) do.
#define MIRAGE_SURFEL_MERGE_RADIUS_PX 0.5

// One surfel cloud as the shaders see it: positions and attributes live in two arrays (SoA), so the
// splat streams 8 bytes per surfel and only the resolve touches normals and colours.
struct SurfelRenderCloud {
  vec4 boxMin;           // xyz quantization box minimum; w: P = N_ref * d^2 (object units squared)
  vec4 boxStep;          // xyz box extent / (2^21 - 1): object units per quantization step
  uint firstSurfel;      // offset into the position and attribute arrays
  uint count;            // N
  uint material;         // index into the material array
  uint coherentMinBlock; // 0: blue-noise order; else the coherent order's smallest block (prefixes round up)
};

// One placed copy of a cloud.
struct SurfelRenderInstance {
  mat4 model;
  mat4 normalMatrix;
  vec4 sphere; // world-space bounding sphere of the cloud's box
  uint cloud;
  float maxScale;    // largest axis scale of `model`: object lengths become world lengths
  uint meshInstance; // mixed scenes: the cluster renderer's instance it fades against (~0u: none)
  uint pad1;
};

// Written per instance by the prefix pass every frame (read by the scan, splat and resolve).
struct SurfelInstanceState {
  mat4 clipFromQuantized; // viewProj * model * dequantization: a quantized position straight to clip space
  uint count;             // k: the prefix length drawn this frame (0: culled)
  uint batchCount;        // ceil(k / MIRAGE_SURFEL_BATCH)
  uint firstBatch;        // exclusive prefix sum of batchCount over instances (scan pass)
  uint firstId;           // 1 + exclusive prefix sum of count: visibility id of surfel 0 (0 = background)
  float radiusPixels;     // splat radius in pixels at clip w = 1: the prefix's Poisson radius (world) * pixel scale
  float fade;             // fraction of pixels the surfels may cover (1 = all; < 1 in the mesh blend band)
  float distance;         // reference depth: eye to the nearest point of the world sphere (>= znear)
  uint firstSurfel;       // the cloud's first surfel in the position and attribute arrays
  // Back-face culling in quantized coordinates (the test is affine-invariant: dot(n, p - eye) has
  // the same sign in object and world space): xyz the eye, w 1 when this instance culls back faces.
  vec4 eyeQuantized;
  vec4 quantStep; // xyz: object units per quantization step (the cloud's boxStep); w: 1 = subgroup merge
  // Stereo: xyz the right eye minus the left in quantized coordinates (eyeQuantized is the left's).
  vec4 stereoEyeQuantized;
};

struct SurfelRenderFrame {
  ViewFrame camera;
  vec4 lightDir; // xyz towards the light, w intensity
  vec4 skyAmbient;
  vec4 groundAmbient;
  vec4 background;  // linear RGBA where no surfel covers the pixel
  float surfelSize; // s: surfel diameter in pixels at the reference depth
  float fadeBand;   // blend band width relative to the switch distance (MIRAGE_SURFEL_MESH_FADE)
  uint flags;       // MIRAGE_SURFEL_*
  uint instanceCount;
  uint idTag; // OR-ed into every visibility id (mixed scenes: tells surfels from clusters; else 0)
  // 1, or 2 in stereo (docs/render.md, "Stereo"): `camera` is the left eye's, the visibility buffer
  // and colour target hold both eyes side by side in rows of 2 * viewport.x pixels.
  uint eyes;
  // Stereo: xyz the right eye minus the left (world); w the right eye's clip x minus the left's
  // (stereoClipDx: the eyes share one projection, so clip y, z and w are the same).
  vec4 stereoEye;
  uint64_t lightAddress; // GpuPointLight[lightCount] (docs/shading.md)
  uint lightCount;
  uint pad0;
};

// Zeroed each frame; indirect arguments and statistics.
struct SurfelRenderCounters {
  uint splatArgs[3]; // compute splat dispatch: batches over (x, y)
  uint totalBatches;
  uint totalSurfels; // sum of k over instances
  uint visibleInstances;
  uint fadingInstances; // instances inside the blend band (0 < fade < 1)
  uint mergedInstances; // visible instances whose splat takes the subgroup merge (quantStep.w)
};

// Push constants of every surfel-render pipeline: addresses of all the arrays.
struct SurfelRenderPush {
  uint64_t frameAddress;     // SurfelRenderFrame
  uint64_t cloudAddress;     // SurfelRenderCloud[]
  uint64_t instanceAddress;  // SurfelRenderInstance[]
  uint64_t stateAddress;     // SurfelInstanceState[]
  uint64_t positionAddress;  // uvec2[]: Surfel::posLo, posHi
  uint64_t attributeAddress; // uvec2[]: Surfel::normal, color
  uint64_t materialAddress;  // GpuMaterial[]
  uint64_t counterAddress;   // SurfelRenderCounters
  uint64_t drawAddress;      // VkDrawIndirectCommand[instanceCount] (raster fallback)
  uint64_t visBufferAddress; // uint64[width * height]: (reverse-Z depth bits << 32) | id
  uint64_t radiusAddress;    // float[]: SurfelCloud::radii, the Poisson radius of each prefix
  uint64_t meshFadeAddress;  // mixed scenes: float[] per cluster instance, the prefix pass writes fade (0: none)
  // uint[] per splat batch: the instance it belongs to (the scan pass writes it), so a splat
  // workgroup finds its instance with one load instead of a binary search of dependent loads.
  uint64_t batchInstanceAddress;
};

#ifdef __cplusplus
static_assert(sizeof(SurfelRenderCloud) == 48, "SurfelRenderCloud layout");
static_assert(sizeof(SurfelRenderInstance) == 160, "SurfelRenderInstance layout");
static_assert(sizeof(SurfelInstanceState) == 144, "SurfelInstanceState layout");
static_assert(sizeof(SurfelRenderFrame) == 488, "SurfelRenderFrame layout");
static_assert(sizeof(SurfelRenderCounters) == 32, "SurfelRenderCounters layout");
static_assert(sizeof(SurfelRenderPush) == 104, "SurfelRenderPush layout");
} // namespace mirage::shaderio
#endif

#endif
