#pragma once
// Blue-surfel renderer (issue 5, rendering): draws progressive surfel clouds (the .mrg 'SURF'
// chunk) with a per-instance prefix length chosen on the GPU every frame. One frame:
//   prefix (cull + k = P / r^2 per instance) -> scan (ids, batches, dispatch) ->
//   splat (compute: 64-bit atomicMax of depth | id; or raster fallback: quads into R32G32_UINT +
//   depth) -> resolve (shading.glsl, the meshes' material model).
// Passes, formulas and the mesh cross-fade: docs/surfels.md, "Rendering".
#include <algorithm>
#include <bit>
#include <cmath>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/shaderio/surfel_link.h"
#include "mirage/shaderio/surfel_render.h"
#include "mirage/surfels/surfel.h"

namespace mirage::render {

enum class SurfelRaster {
  Auto,    // compute when the device has 64-bit buffer atomics, else raster
  Compute, // splat with 64-bit atomics into a buffer (one atomic per pixel-sized surfel)
  Raster,  // fallback: indirect draws of screen-aligned quads, depth-tested
};
inline constexpr EnumName<SurfelRaster> kSurfelRasterNames[] = {
    {SurfelRaster::Auto, "auto"}, {SurfelRaster::Compute, "compute"}, {SurfelRaster::Raster, "raster"}};
const char* toString(SurfelRaster raster);
// "auto", "compute" or "raster"; anything else is an error naming the choices.
Result<SurfelRaster> parseSurfelRaster(std::string_view text);

// The compute splat's subgroup merge (lanes of a subgroup that hit the same pixel pool their values
// first, and one lane per pixel touches the visibility buffer; the image is the same bit for bit).
enum class SurfelMerge {
  Off,  // the plain splat pipeline (no subgroup operations)
  On,   // every instance merges
  Auto, // per instance, on the GPU: where its disc radius is under MIRAGE_SURFEL_MERGE_RADIUS_PX
};
inline constexpr EnumName<SurfelMerge> kSurfelMergeNames[] = {
    {SurfelMerge::Off, "off"}, {SurfelMerge::On, "on"}, {SurfelMerge::Auto, "auto"}};
const char* toString(SurfelMerge merge);
// "off", "on" or "auto"; anything else is an error naming the choices.
Result<SurfelMerge> parseSurfelMerge(std::string_view text);

// How the renderer stores each cloud for splatting (files keep the blue-noise order either way).
enum class SurfelOrder {
  Blue,        // the file's order: prefix k is exactly the first k surfels
  Coherent,    // Morton-sorted within geometrically growing blocks of >= 1024 (one splat batch)
  Coherent256, // the same with blocks of >= 256: less rounding for small prefixes, less coherence
};
inline constexpr EnumName<SurfelOrder> kSurfelOrderNames[] = {
    {SurfelOrder::Blue, "blue"}, {SurfelOrder::Coherent, "coherent"}, {SurfelOrder::Coherent256, "coherent256"}};
const char* toString(SurfelOrder order);
// "blue", "coherent" or "coherent256"; anything else is an error naming the choices.
Result<SurfelOrder> parseSurfelOrder(std::string_view text);
// The order `mirage render --surfels` and SurfelRenderer::create use unless told otherwise. H200,
// 1080p, 1024 copies of a 100 k cloud (docs/surfels.md, session 10): coherent256 splats faster than
// blue both with every surfel drawn (1.124x) and with adaptive prefixes (1.064x, its rounding adds
// 3 % surfels); coherent's 1024-surfel blocks add 12 % there and lose (0.92x).
inline constexpr SurfelOrder kDefaultSurfelOrder = SurfelOrder::Coherent256;
// The smallest block of a coherent order (0 for the blue-noise order).
inline constexpr uint32_t coherentMinBlock(SurfelOrder order) {
  return order == SurfelOrder::Coherent ? MIRAGE_SURFEL_BATCH : order == SurfelOrder::Coherent256 ? 256u : 0u;
}

// Coherent order (docs/surfels.md, "Coherent order"): the end of the block holding position i of a
// cloud of n surfels. Blocks: size max(minBlock, 2^floor(log2 i) >> SHIFT), aligned to multiples of
// their size (minBlock a power of two >= 32; the GLSL twin is in surfel_render_prefix.comp).
inline uint32_t coherentBlockEnd(uint32_t i, uint32_t n, uint32_t minBlock) {
  uint32_t size = minBlock;
  if (i > 0) size = std::max(size, (1u << (31 - std::countl_zero(i))) >> MIRAGE_SURFEL_COHERENT_BLOCK_SHIFT);
  uint32_t start = i - i % size;
  return n - start <= size ? n : start + size; // no overflow near 2^32
}
// A prefix length rounded up to the end of its block (0 stays 0): the first k' surfels of the
// coherent order are the same set as the first k' of the blue-noise order.
inline uint32_t coherentPrefix(uint32_t k, uint32_t n, uint32_t minBlock) {
  return k == 0 ? 0 : coherentBlockEnd(k - 1, n, minBlock);
}
// The coherent order of a cloud: at[i] is the index (in the cloud's blue-noise order) of the surfel
// stored at position i. A permutation within each block, by Morton code of the quantized position
// (ties by index).
std::vector<uint32_t> coherentSurfelOrder(const surfels::SurfelCloud& cloud, uint32_t minBlock);

// What the renderer draws: clouds (each with the material its metallic / roughness come from) and
// placed copies of them.
struct SurfelScene {
  struct Cloud {
    const surfels::SurfelCloud* cloud = nullptr; // must outlive SurfelRenderer::create only
    Material material;                           // base colour is already in the surfels' colours
  };
  struct Placement {
    uint32_t cloud = 0;
    glm::mat4 transform{1.0f};
    uint32_t meshInstance = UINT32_MAX; // mixed scenes: the ClusterRenderer instance of the same object
  };
  std::vector<Cloud> clouds;
  std::vector<Placement> instances;
  std::vector<PointLight> lights; // besides the key light (docs/shading.md)
};

struct SurfelRenderSettings {
  RenderSettings base;                      // size, camera, lighting, background
  float surfelSize = 2.0f;                  // s: surfel diameter in pixels at the reference depth
  SurfelRaster raster = SurfelRaster::Auto; // resolved against the device at render time
  bool frustumCulling = true;               // instances outside the view draw nothing
  bool allSurfels = false;                  // benchmark: every instance splats all N (no prefix)
  // Surfels of single-sided clouds facing away from the eye are skipped (as the mesh renderers cull
  // back faces): they would lose the depth test anyway. Off by default: on the H200 the normal
  // reads cost more than the skipped splats save (1080p, 102 M surfels: 85.5 G surfels/s culled vs
  // 93.1 unculled; docs/surfels.md), the splat being latency- rather than atomic-bound.
  bool backfaceCulling = false;
  // Compute splat variant, meant for the coherent order; timed against the plain splat by `bench
  // surfels --merge all`. H200: it pays where many surfels share a pixel (every surfel of 1024
  // copies drawn: 133 G surfels/s vs 102 plain, coherent256) and costs with adaptive prefixes
  // (~1 surfel per pixel: splat 0.226 vs 0.184 ms), hence the per-instance choice of Auto.
  SurfelMerge merge = SurfelMerge::Auto;
  // Discs in the surfels' tangent planes (ellipses on screen, docs/surfels.md "Oriented discs")
  // rather than facing the viewer: silhouettes stop bloating by a disc radius where discs are large
  // (near the mesh switch). Only discs of >= MIRAGE_SURFEL_ORIENTED_MIN_RADIUS_PX read the normal.
  bool orientedDiscs = true;
  // Cross-fade with a mesh pass: instances nearer than the switch distance (where k reaches N)
  // draw nothing, and surfels cover a dithered share of pixels over `fadeBand` x that distance
  // beyond it (0: hard switch). Off: surfels everywhere.
  bool meshFade = false;
  float fadeBand = 0.5f;
  bool readInstanceStates = false; // fill SurfelRenderOutput::prefix / fade (tests, --stats); render() only
  // Stereo (docs/render.md, "Stereo"): the eyes are stereoEyes(base.camera, ipd) (camera.h). One
  // prefix selection serves both (union of the frusta, k from the nearer eye); each workgroup
  // splats its surfels into both halves of a (2 * base.width) x base.height target, left|right,
  // and one resolve shades both. Compute splat only.
  std::optional<float> stereoIpd;
};

struct SurfelRenderOutput {
  RenderOutput image; // srgb (+ linear), pass times in image.stats.passTimes
  SurfelRaster raster = SurfelRaster::Auto;
  uint32_t visibleInstances = 0;
  uint32_t fadingInstances = 0;
  uint32_t mergedInstances = 0;   // visible instances whose compute splat took the subgroup merge
  uint64_t surfelsSplatted = 0;   // sum of k over instances
  std::vector<uint32_t> prefix;   // per instance: k (readInstanceStates)
  std::vector<float> fade;        // per instance: share of pixels the surfels may cover
  std::vector<float> distance;    // per instance: reference depth used for k
  std::vector<uint8_t> merged;    // per instance: 1 when its splat took the subgroup merge
  std::vector<uint32_t> idBuffer; // per pixel (both eyes in stereo): visibility id (0 = background), readInstanceStates
  std::vector<uint32_t> depthBits; // per pixel: reverse-Z depth bits of the compute splat (readInstanceStates)
};

// The CPU mirror of the GPU prefix length (shaders/surfel_render_prefix.comp): P = N_ref * d^2 in
// world units², `distance` the reference depth, `pixelScale` = |proj[1][1]| * height / 2.
// r = s * (distance / pixelScale) / 2 and k = clamp(ceil(P / r²), 1, N).
inline uint32_t surfelPrefix(float P, uint32_t N, float distance, float pixelScale, float surfelSize) {
  if (N == 0) return 0;
  if (!(P > 0.0f)) return N;
  float r = surfelSize * distance / (2.0f * pixelScale);
  float k = std::min(std::ceil(P / (r * r)), float(N));
  return uint32_t(std::max(k, 1.0f));
}

// Distance at which the prefix reaches N (the cloud is exhausted): the mesh/surfel switch distance.
inline float surfelSwitchDistance(float P, uint32_t N, float pixelScale, float surfelSize) {
  return N == 0 || !(P > 0.0f) ? 0.0f : 2.0f * pixelScale * std::sqrt(P / float(N)) / surfelSize;
}

// Mixed scenes (docs/render.md, "Mixed scenes"): the cluster renderer runs this renderer's prefix
// and splat inside its own frame, with its camera, into its 64-bit visibility buffer, and shades the
// surfel pixels in its own resolve. What that frame hands over:
struct SurfelStageFrame {
  shaderio::ViewFrame camera{};  // the cluster frame's camera (viewFrame); stereo: the left eye's
  uint64_t visBufferAddress = 0; // the shared uint64 per pixel buffer (zeroed by the caller)
  uint64_t meshFadeAddress = 0;  // float per mesh instance: the prefix pass writes each fade
  uint32_t slot = 0;             // the frame slot (0..kMaxFramesInFlight - 1) the caller records
  // Stereo: 2 eyes side by side in the buffer (rows of 2 * viewport.x); xyz the right eye minus
  // the left, w the right eye's clip x minus the left's (stereoClipDx, camera.h).
  uint32_t eyes = 1;
  glm::vec4 stereoEye{0.0f};
};
struct SurfelStageStats {
  uint32_t visibleInstances = 0; // instances drawing surfels (in view, fade > 0)
  uint32_t fadingInstances = 0;  // of those, inside the blend band (0 < fade < 1)
  uint64_t surfelsSplatted = 0;
};

class SurfelRenderer {
public:
  // Uploads every cloud (positions and attributes as two arrays, in `order`) and the instances.
  // Errors: no clouds or instances, an instance naming a missing cloud, more than 2^32 - 2 surfels.
  static Result<std::unique_ptr<SurfelRenderer>> create(gpu::Context& context, const SurfelScene& scene,
                                                        SurfelOrder order = kDefaultSurfelOrder);
  ~SurfelRenderer();

  // One frame, synchronously: record + submit and wait + collect (slot 0), then the instance
  // states and the image read back as the settings ask.
  Result<SurfelRenderOutput> render(const SurfelRenderSettings& settings);

  // Frames in flight, as ClusterRenderer::record / collect (cluster_renderer.h): record() writes
  // `slot`'s frame data and records the whole frame into the caller's command buffer (nothing is
  // submitted); once the caller's fence for it signalled, collect(slot) gives the frame's counters
  // and pass times (no image: it is colorTarget(); readInstanceStates is refused here). Slots
  // 0..kMaxFramesInFlight - 1, reused only after their frame completed; frames run on one queue
  // in the order recorded (they share GPU scratch, which each frame's first barrier orders after
  // everything submitted before it). A size change replaces the targets without a device wait:
  // the old ones live until the slots that may use them completed (each slot has its own
  // descriptor set). Errors record nothing.
  Status record(VkCommandBuffer cmd, const SurfelRenderSettings& settings, uint32_t slot);
  Result<SurfelRenderOutput> collect(uint32_t slot);
  // The colour target of the last recorded frame: VK_FORMAT_R16G16B16A16_SFLOAT, linear, (2 x)
  // width x height; left by record() in VK_IMAGE_LAYOUT_GENERAL, last written by compute shaders.
  // The caller transitions it for its own use and may leave it in any layout.
  const gpu::Image& colorTarget() const;
  const Bounds& worldBounds() const;
  uint64_t surfelCount() const;    // stored surfels (all clouds, once each)
  uint64_t instancedCount() const; // sum over instances of their cloud's N
  SurfelOrder order() const;

  // Mixed-scene stage (used by ClusterRenderer): write the frame constants of frame.slot (ids
  // tagged with MIRAGE_SURFEL_ID_TAG, cross-fade on), then record clear + prefix + scan, the
  // splat, and at the frame's end the counters into the slot's readback, into the caller's command
  // buffer, timed with the caller's timer. Needs 64-bit buffer atomics. The stage's frames may be
  // in flight like the caller's (per-slot frame data and readbacks, shared GPU scratch).
  Status stagePrepare(const SurfelRenderSettings& settings, const SurfelStageFrame& frame);
  void stageCmdClear(VkCommandBuffer cmd);
  void stageCmdPrefix(VkCommandBuffer cmd, gpu::GpuTimer& timer);
  void stageCmdSplat(VkCommandBuffer cmd, gpu::GpuTimer& timer);
  // barriers: the counters' last writes (prefix, scan) visible to transfers; the caller makes the
  // copy visible to the host, as for its own readbacks.
  void stageCmdFinish(VkCommandBuffer cmd);
  shaderio::ClusterSurfelLink stageLink() const;
  SurfelStageStats stageStats(uint32_t slot) const; // after the caller's submission of that slot completed

  struct Impl;

private:
  explicit SurfelRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::render
