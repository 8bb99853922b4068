#pragma once
// GPU-driven cluster-LOD renderer for baked .mrg assets (issue 4, first slice). Per frame the CPU
// records a fixed command sequence whatever the scene size:
//   instance cull -> cluster selection (LOCALCUT + frustum + normal cones) -> raster args ->
//   pass 1 visibility raster (clusters visible last frame) -> HZB -> pass 2 occlusion cull + raster
//   (the rest) -> resolve (which also records the clusters owning pixels: next frame's pass 1).
// Rasterizers: mesh shaders | one indirect draw | compute 64-bit atomics | hybrid (compute for
// small triangles, mesh/indirect for large ones, into the same 64-bit buffer).
// Every backend writes the same visibility semantics (visible-cluster index + triangle id, nearest
// depth wins) and one resolve pass shades it with the forward renderer's material model, so all
// backends give the same image. Passes and data layout: docs/render.md.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/lod/cluster_pvs.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/render/oit.h"
#include "mirage/render/surfel_renderer.h"

namespace mirage::render {

enum class RasterBackend {
  Auto,     // hybrid with 64-bit atomics and mesh shaders; else compute, mesh, indirect (first available)
  Mesh,     // VK_EXT_mesh_shader: one mesh workgroup per visible cluster
  Indirect, // one vkCmdDrawIndirect: an instance per visible cluster, 3 x 128 vertices each
  Compute,  // software rasterizer: atomicMax of (depth << 32 | id) into a 64-bit buffer
  Hybrid,   // per cluster: compute for small triangles, mesh (or indirect) for large / near-plane ones
};
inline constexpr EnumName<RasterBackend> kRasterBackendNames[] = {{RasterBackend::Auto, "auto"},
                                                                  {RasterBackend::Mesh, "mesh"},
                                                                  {RasterBackend::Indirect, "indirect"},
                                                                  {RasterBackend::Compute, "compute"},
                                                                  {RasterBackend::Hybrid, "hybrid"}};
const char* toString(RasterBackend backend);
// "auto", "mesh", "indirect", "compute" or "hybrid"; anything else is an error naming the choices.
Result<RasterBackend> parseRasterBackend(std::string_view text);

// How alpha BLEND clusters are rasterized into the per-pixel transparency lists (docs/render.md,
// "Blend rasters"). Every choice appends the same nodes, so the composite and the image agree.
enum class BlendRaster {
  Auto,     // compute where the blend queue runs (64-bit buffer atomics), else hybrid, else compute
            // (docs/render.md "Blend rasters")
  Compute,  // cluster_raster_blend.comp: a workgroup per cluster, large triangles through the blend queue
  Hybrid,   // per cluster as the hybrid opaque split (hybridThreshold): large triangles to hardware
  Hardware, // every blend cluster by mesh shaders (indirect draws with --raster indirect or without them)
};
inline constexpr EnumName<BlendRaster> kBlendRasterNames[] = {{BlendRaster::Auto, "auto"},
                                                              {BlendRaster::Compute, "compute"},
                                                              {BlendRaster::Hybrid, "hybrid"},
                                                              {BlendRaster::Hardware, "hardware"}};
const char* toString(BlendRaster blend);
// "auto", "compute", "hybrid" or "hardware"; anything else is an error naming the choices.
Result<BlendRaster> parseBlendRaster(std::string_view text);

// How the hardware rasters (mesh, indirect, hybrid's hardware list) draw the two stereo eyes
// (docs/render.md, "Stereo"). The compute raster draws both eyes in one dispatch either way.
enum class StereoMode {
  Auto,      // per-eye viewports (multiview measured slower on the H100: docs/render.md "Stereo")
  Multiview, // VK_KHR_multiview: each draw once with view mask 0b11 into 2-layer targets
  Viewports, // each draw once per eye with its viewport over its half of the side-by-side targets
};
inline constexpr EnumName<StereoMode> kStereoModeNames[] = {
    {StereoMode::Auto, "auto"}, {StereoMode::Multiview, "multiview"}, {StereoMode::Viewports, "viewports"}};
const char* toString(StereoMode mode);
// "auto", "multiview" or "viewports"; anything else is an error naming the choices.
Result<StereoMode> parseStereoMode(std::string_view text);

// How the selection pass finds the cut clusters (docs/render.md, "Selection").
enum class SelectionMode {
  Auto,      // hierarchy from kHierarchyInstances instances on, else flat (measured on the H200, below)
  Flat,      // one thread per (visible instance, cluster of its level range)
  Hierarchy, // breadth-first traversal of per-level BVHs over the DAG's groups: work follows the cut
  Dag,       // the dissertation's DAG traversal: from the roots down a tree of the DAG's groups
};
// H200, select pass: 2500 instances flat 0.010 ms / hierarchy 0.022; 65025 instances 0.150 / 0.030;
// one 21 M-triangle mesh close up 0.020 / 0.190 (the flat pass tests 335 k clusters faster than the
// traversal's six dependent dispatches run). The flat cost grows with instances, the traversal's
// is mostly fixed: the crossover lies near 10 k instances.
constexpr uint32_t kHierarchyInstances = 8192;
inline constexpr EnumName<SelectionMode> kSelectionModeNames[] = {{SelectionMode::Auto, "auto"},
                                                                  {SelectionMode::Flat, "flat"},
                                                                  {SelectionMode::Hierarchy, "hierarchy"},
                                                                  {SelectionMode::Dag, "dag"}};
const char* toString(SelectionMode mode);
// "auto", "flat", "hierarchy" or "dag"; anything else is an error naming the choices.
Result<SelectionMode> parseSelectionMode(std::string_view text);

// Debug views (docs/render.md, "Debug views"): a separate resolve colours each pixel by what it
// shows instead of shading it (colours: shaderio/debug_view.h). Not with stereo yet; alpha BLEND
// surfaces are not drawn in a debug view.
enum class DebugView {
  None,     // shaded image
  Clusters, // a stable hash colour per (instance, cluster): cluster boundaries
  Lod,      // the cluster's DAG level, fixed ramp (0 = full detail)
  Density,  // triangles per pixel (1 / the triangle's projected area), log2 heat map, 1 marked
  Overdraw, // samples rasterized per pixel before the depth test
};
inline constexpr EnumName<DebugView> kDebugViewNames[] = {{DebugView::None, "none"},
                                                          {DebugView::Clusters, "clusters"},
                                                          {DebugView::Lod, "lod"},
                                                          {DebugView::Density, "density"},
                                                          {DebugView::Overdraw, "overdraw"}};
const char* toString(DebugView view);
// "none", "clusters", "lod", "density" or "overdraw"; anything else is an error naming the choices.
Result<DebugView> parseDebugView(std::string_view text);

// Default LOD threshold in pixels; the CLI binds it. The build's shading-aware error
// (lod::BuildConfig::normalWeight) is tuned so that 1 px matches the full mesh (docs/lod.md).
inline constexpr float kDefaultTauPixels = 1.0f;

struct ClusterRenderSettings {
  RenderSettings base;                         // size, camera, lighting, background
  float tauPixels = kDefaultTauPixels;         // LOD threshold: projected error allowed, in pixels
  RasterBackend raster = RasterBackend::Auto;  // resolved against the device at render time
  BlendRaster blendRaster = BlendRaster::Auto; // BLEND clusters (scenes with blend materials only)
  bool frustumCulling = true;                  // instances and clusters outside the view are skipped
  bool flagBackFaces = false;                  // debug: draw back faces in magenta (crack tests)
  // GPU residency: this frame's camera is a cut (a jump, not a step), whatever isCameraCut says of
  // it: the prefetch is computed again for it. Set it on the cut's frame only.
  bool cameraCut = false;
  DebugView debugView = DebugView::None; // debug: colour pixels by cluster, level, density or overdraw
  // Hybrid: clusters whose estimated triangle edge (projected bounding-sphere diameter /
  // sqrt(triangles)) is below this many pixels go to the compute rasterizer, the rest (and those
  // reaching the near plane) to the hardware path. To be tuned on the H200 (docs/render.md).
  float hybridThreshold = 16.0f;
  // Compute raster: clusters whose every triangle provably takes the per-thread 32-bit walk (small
  // on screen, beyond the near plane, not masked) are drawn by a kernel with that walk alone
  // (docs/render.md, "Lean raster"); off: the general kernel draws them. Same image either way.
  bool leanRaster = true;
  // Compute blend raster: a blended triangle whose pixel box exceeds this many pixels goes to the
  // blend queue, whose tiles a second dispatch spreads over the whole GPU, instead of being walked
  // by its cluster's workgroup alone (docs/render.md, "Blend rasters"); +inf: no queue. The queue
  // needs 64-bit buffer atomics (without them every triangle stays with its workgroup).
  float blendQueuePixels = 1024.0f;
  // Transparency node pool (docs/render.md, "Transparency"): blended fragments per pixel on average
  // (12 bytes each; 1..64; 0: 4, or 8 once particles share the lists), capped by the device's
  // storage-buffer range. Past it, a fragment takes the place of its pixel's farthest listed one if
  // nearer, else is dropped (counted either way).
  uint32_t oitNodesPerPixel = 0;
  // How the fragments are stored (render/oit.h): Fixed (fixed slots per pixel, one rasterization,
  // placed again as Packed's ranges where a pixel outnumbers its slots), Packed (per-pixel ranges,
  // two rasterizations) or LinkedList; frames that draw particle billboards take the linked lists
  // (Fixed and Packed are then ignored). Fixed stores as Packed with the hybrid and hardware blend
  // rasters.
  OitMode oit = OitMode::Fixed;
  // Tests: queue at most this many triangles a frame (the queue's capacity when larger); the rest
  // are walked by their cluster's workgroup, as when the queue is full.
  uint32_t blendQueueLimit = UINT32_MAX;
  // Two-pass HZB occlusion culling against this renderer's previous frame (correct on any frame,
  // faster when consecutive frames are alike).
  bool occlusionCulling = false; // off by default: on the H200 it cost more than it saved (docs/render.md)
  bool coneCulling = true;       // per-cluster normal cones drop back-facing clusters of single-sided instances
  bool transparency = true;      // alpha BLEND clusters drawn (off: opaque and MASK only, the viewer's switch)
  // Foveation: tau grows with a sphere's eccentricity from the gaze beyond the fovea's radius
  // (fovealTauScale in shaderio/lod_error.h). The gaze point is in normalized screen coordinates
  // (0,0 top left, 1,1 bottom right).
  bool foveation = false;
  glm::vec2 foveaGaze{0.5f, 0.5f};
  float foveaRadiusDegrees = 5.0f;
  // Mixed scenes (docs/render.md, "Mixed scenes"): a surfel renderer whose placements name this
  // renderer's instances (SurfelScene::Placement::meshInstance) draws them far away, into the same
  // visibility buffer and resolve, cross-fading with the meshes per pixel. Its surfelSize and
  // fadeBand apply (meshFade is forced on); needs the compute or hybrid backend.
  SurfelRenderer* surfels = nullptr;
  SurfelRenderSettings surfelSettings;
  SelectionMode selection = SelectionMode::Auto; // all select exactly the same clusters
  // Cull with the cluster PVS given to setPvs (if any); off renders as if none were set.
  bool pvsCulling = true;
  // Stereo (docs/render.md, "Stereo"): the eyes are stereoEyes(base.camera, ipd) (camera.h). One
  // selection serves both (union of the frusta, LOD error from the nearer eye), then both eyes are
  // rasterized and resolved in one pass each into the halves of a (2 * base.width) x base.height
  // target, left|right; mixed frames' surfels too (one prefix selection, from the nearer eye).
  // Refused with owned-cluster readback.
  std::optional<float> stereoIpd;
  StereoMode stereoMode = StereoMode::Auto; // stereo: multiview or per-eye viewports (multiview refused where absent)
  // Tests: read back which (instance, mesh-local cluster) pairs own a pixel of this frame (the
  // occlusion history the resolve writes; needs occlusionCulling) into ownedClusters.
  bool readOwnedClusters = false;
  // Tests: read back the 64-bit visibility buffer (compute and hybrid backends) into `visibility`.
  bool readVisibility = false;
  // Particle billboards (render/particle_draw.h; docs/render.md, "Particles"), depth-tested against
  // the opaque depth and appended to the BLEND clusters' per-pixel lists, so the composite sorts
  // both together; null: none (nor in debug views).
  ParticleDraw* particles = nullptr;
};

// GPU residency of paged DAGs (docs/render.md, "Residency"): the clusters' geometry lives in a
// pool of fixed-size units within a byte budget; the selection draws the residency-aware cut of the
// resident pages and writes page feedback, from which lod::ResidencyManager picks the pages to
// load (a bounded number per frame) and to evict. A loaded page's units are reserved at once, its
// bytes read on background threads (lod::PageStream, from the file or URL), uploaded through a
// staging buffer in the frame's command buffer when they arrive, and drawn once its dependencies
// are drawn too; no frame waits for I/O.
// CPU milliseconds of one residency frame by phase, on the thread that prepares it (render() or
// record()) unless named otherwise; a camera cut's wall time is spent in these (docs/render.md,
// "Residency", "Where a converging frame's time goes").
struct ResidencyTimes {
  double takeMs = 0;     // arrived pages taken from the stream
  double uploadMs = 0;   // arrived pages moved to their pool units and staged (records, cones, child pages too)
  double prefetchMs = 0; // the view's prefetch computed (0 when the last one still holds)
  double stepMs = 0;     // feedback merged with the prefetch, the manager's step, units freed and reserved
  double requestMs = 0;  // reads queued on the stream
  double publishMs = 0;  // pages made drawn, the drawn-page table staged, figures
  double setupMs = 0;    // the rest of the frame's preparation (plan, targets, descriptors, frame data)
  double submitMs = 0;   // render(): recording, submit and wait for the frame's fence (the GPU's time in it)
  double collectMs = 0;  // the feedback read back and counted
  double readbackMs = 0; // render(): the image (or other buffers) read back
  double readWaitMs = 0; // renderConverged: waiting for a read before this frame (nothing else to do)
  double decodeMs = 0;   // reader threads, not this one: reading, checking and decoding the pages taken
  double layoutMs = 0;   // reader threads: laying the uploads of the pages taken out
  double renderThreadMs() const {
    return takeMs + uploadMs + prefetchMs + stepMs + requestMs + publishMs + setupMs + submitMs + collectMs +
           readbackMs + readWaitMs;
  }
  ResidencyTimes& operator+=(const ResidencyTimes& o);
};

struct ResidencyStats {
  bool enabled = false;
  uint64_t budgetBytes = 0;   // the budget asked for
  uint64_t unitBytes = 0;     // one pool unit (kPoolUnitBytes)
  uint64_t poolBytes = 0;     // the pool as allocated: units * unitBytes (<= budget) + index padding
  uint64_t residentBytes = 0; // the units resident pages hold (<= budget), after this frame's step
  uint64_t geometryBytes = 0; // the bytes those pages' vertices, vertex ids and indices take in them
  uint64_t recordBytes = 0;   // the bytes their cluster records (GpuCluster) take in them
  // GPU bytes kept outside the budget that grow with the scene, from the buffers as allocated: the
  // per-cluster tables (the cluster-slot table, 4 B a cluster, and the hierarchical selections'
  // leaf lists, 8 B; the cluster records live in the pool's units with their pages, within the
  // budget), and the trees' nodes (per group, not per cluster).
  uint64_t clusterTableBytes = 0;
  uint64_t treeNodeBytes = 0;
  uint64_t clusters = 0;      // clusters of every mesh
  uint64_t bytesRead = 0;     // page bytes read from the file or URL so far (as stored)
  uint64_t bytesReceived = 0; // bytes the file or URL delivered since it was opened (index and root pages too)
  uint32_t pages = 0;         // pages of every mesh
  uint32_t units = 0;
  uint32_t residentPages = 0; // pages holding units (reserved or uploaded)
  uint32_t drawnPages = 0;    // resident pages the selection draws (uploaded, dependencies drawn)
  uint32_t pending = 0;       // resident pages whose bytes have not arrived yet
  uint32_t requested = 0;     // missing pages this frame's selection asked for
  uint32_t loaded = 0;        // pages this frame's step made resident (their reads asked for)
  uint32_t uploaded = 0;      // pages this frame uploaded (bytes arrived)
  uint32_t inTransit = 0;     // pending pages whose bytes are on the transfer queue (async uploads)
  uint32_t evicted = 0;       // pages this frame evicted
  uint32_t unfit = 0;         // requests this frame left for later (no room or no loads left)
  bool stepped = false;       // this frame acted on feedback (false for the first frame)
  bool prefetched = false;    // this frame computed the view's prefetch (a camera cut, a new size or tau)
  ResidencyTimes times;       // where the frame's CPU time went
};

struct ClusterResidencySettings {
  uint64_t budgetBytes = 0;         // pool bytes for page geometry (> 0)
  uint32_t maxUploadsPerFrame = 32; // pages made resident per frame at most (dependencies included)
  uint32_t maxReadsInFlight = 32;   // lod::PageStreamConfig::maxInFlight: a frame's uploads' worth, so a
                                    // camera cut is not paced at 8 pages a frame (decoded pages: ~0.3 MB each)
  // Prefetch (docs/render.md, "Residency"): when the view changes, the pages every level of its full
  // cut needs (lod::prefetchFeedback per instance, frustum-culled) join each frame's feedback, so a
  // camera cut asks for all its levels at once instead of one level per frame round trip.
  bool prefetch = true;
  // Where a page's geometry goes to the GPU (docs/render.md, "Residency"): Transfer copies it on
  // the transfer queue (the copy engines, beside the frames' work) into device memory as soon as
  // it is read, and a later frame moves it into the pool with a device copy; Frame copies it from
  // host memory inside the frame that draws it first. Auto: Frame (the transfer queue measured no
  // faster: docs/render.md). Transfer without a transfer queue (gpu::Context) uses the queue.
  enum class Uploads : uint8_t { Auto, Frame, Transfer };
  Uploads uploads = Uploads::Auto;
};
inline constexpr EnumName<ClusterResidencySettings::Uploads> kUploadsNames[] = {
    {ClusterResidencySettings::Uploads::Auto, "auto"},
    {ClusterResidencySettings::Uploads::Frame, "frame"},
    {ClusterResidencySettings::Uploads::Transfer, "transfer"}};

struct ClusterStats {
  uint32_t instancesVisible = 0;         // inside the frustum with a level range (minus occlusion-culled late ones)
  uint32_t clustersTested = 0;           // (instance, cluster) pairs the selection pass looked at
  uint32_t nodesTested = 0;              // hierarchical selection: (instance, BVH node) pairs visited
  uint32_t selectionPasses = 0;          // hierarchical selection: dispatches per phase (deepest BVH + 1)
  uint32_t selectRows = 0;               // workgroup rows of the selection dispatch (<= 65535)
  uint32_t clustersSelected = 0;         // on the LOCALCUT cut and inside the frustum
  uint32_t clustersFrustumCulled = 0;    // on the cut but outside the frustum
  uint32_t clustersBackfaceCulled = 0;   // selected, but the normal cone faces away
  uint32_t clustersPass1 = 0;            // occlusion: drawn in pass 1 (visible last frame)
  uint32_t clustersOcclusionTested = 0;  // occlusion: pass-2 candidates tested against the HZB
  uint32_t clustersOcclusionCulled = 0;  // occlusion: candidates behind the HZB (not drawn)
  uint32_t instancesLate = 0;            // occlusion: visible instances with no pixel last frame
  uint32_t instancesOcclusionCulled = 0; // occlusion: late instances behind the HZB (not selected)
  uint32_t historyKept = 0;              // occlusion: clusters owning a pixel (next frame's pass 1)
  uint32_t clustersDrawn = 0;            // rasterized (both passes, both lists)
  uint32_t clustersHardware = 0;         // hybrid: drawn by the mesh/indirect path
  uint32_t clustersLean = 0;             // compute: drawn by the lean raster (ClusterRenderSettings::leanRaster)
  uint32_t trianglesNearClipped = 0;     // compute raster: triangles clipped at the near plane
  uint32_t clustersOverflow = 0;         // selected beyond the visible-buffer capacity (dropped)
  uint32_t clustersBlend = 0;            // alpha BLEND: drawn into the transparency lists (in clustersDrawn)
  uint32_t clustersBlendHardware = 0;    // of those, drawn by the hardware blend raster
  uint32_t blendQueueTriangles = 0;      // blended triangles drawn through the blend queue
  uint32_t blendQueueTiles = 0;          // their 8 x 8 pixel tiles
  uint32_t blendQueueOverflow = 0;       // large ones past the queue's capacity (walked by their cluster)
  uint32_t oitFragments = 0;             // blended fragments in front of the opaque depth
  uint32_t oitPoolOverflow = 0;          // fragments under their pixel's cap past the node pool (each drops its
                                         // pixel's farthest)
  uint32_t oitLayersDropped = 0;         // fragments beyond MIRAGE_OIT_MAX_LAYERS of a pixel (farthest dropped):
                                         // past the per-pixel cap at append, or listed past it at the composite
  double msl = 0.0;                      // Mean Squared Layers of the transparency lists (render/oit.h)
  uint32_t oitFixedSlots = 0;            // --oit fixed: keys per pixel of the fixed slots (0: not used)
  bool oitFixedRedone = false;           // a pixel outnumbered its fixed slots: the fragments placed again as
                                         // packed ranges (a second rasterization)
  uint64_t trianglesRasterized = 0;      // triangles of the drawn clusters
  uint32_t instancesPvsCulled = 0;       // cell PVS: instances in the frustum with no visible cluster
  uint32_t clustersPvsCulled = 0;        // cell PVS: clusters on the cut outside the cluster PVS
  bool pvs = false;                      // the cell's cluster PVS culled this frame
  bool occlusion = false;                // occlusion culling ran
  RasterBackend raster = RasterBackend::Auto;         // the backend that ran
  BlendRaster blendRaster = BlendRaster::Compute;     // the blend raster that ran (Auto resolved)
  StereoMode stereoMode = StereoMode::Auto;           // stereo: the mode that ran (Auto: mono frame)
  SurfelStageStats surfels;                           // mixed scenes: instances drawn (partly) as surfels
  SelectionMode selection = SelectionMode::Hierarchy; // the mode that ran (Auto resolved)
  ResidencyStats residency;                           // GPU residency (enabled: the renderer has it)
};

// One pixel of the 64-bit visibility buffer (ClusterRenderSettings::readVisibility): the nearest
// sample's depth bits and what drew it, decoded through the visible list (so it does not depend on
// the list entry a cluster happened to get); instance and cluster ~0u where nothing (or a surfel) is.
struct VisibilitySample {
  uint32_t depthBits = 0;
  uint32_t instance = UINT32_MAX;
  uint32_t cluster = UINT32_MAX; // global cluster id
  uint32_t triangle = 0;
  bool operator==(const VisibilitySample&) const = default;
};

struct ClusterRenderOutput {
  RenderOutput image; // srgb (+ linear), pass times in image.stats.passTimes
  ClusterStats stats;
  std::vector<std::pair<uint32_t, uint32_t>> ownedClusters; // readOwnedClusters: (instance, mesh-local cluster)
  std::vector<VisibilitySample> visibility; // readVisibility: the target's pixels, row by row (stereo: both eyes)
};

class ClusterRenderer {
public:
  // Uploads every DAG, the instances, materials and textures. Refuses clusters larger than the
  // mesh-shader limits (MIRAGE_CLUSTER_MAX_TRIANGLES / _VERTICES) with a clear error.
  static Result<std::unique_ptr<ClusterRenderer>> create(gpu::Context& context, const lod::LodAsset& asset);
  // With GPU residency of a paged asset opened for on-demand pages: the tables give the cluster
  // records, the root pages are uploaded by the first frame, every other page is read as the
  // feedback asks. `asset` must outlive the renderer (its reader serves the pages). Errors: a
  // budget below the root pages, a page that does not match its table (when it arrives: that
  // frame's error).
  static Result<std::unique_ptr<ClusterRenderer>> create(gpu::Context& context, const lod::PagedLodAsset& asset,
                                                         const ClusterResidencySettings& residency);
  ~ClusterRenderer();

  // One frame, synchronously: record + submit and wait + collect, then the owned clusters and the
  // image read back as the settings ask.
  Result<ClusterRenderOutput> render(const ClusterRenderSettings& settings);

  // GPU residency: frames (synchronous, no image read back but the last) until one after the first
  // (which steps on the feedback of what was drawn before) loads, uploads and evicts nothing with no
  // read pending (between frames that only wait for reads, it waits for the next page to arrive),
  // then that frame again with the settings' readback: its image is the converged one. Without residency: render().
  // framesToConverge counts the frames before the stable one; `frames` holds each frame's residency figures (the last
  // one's too). `readEveryFrame`: every frame is read back as the settings ask and its sRGB image kept (the progressive
  // start: what a viewer would have shown while the pages streamed in).
  struct Converged {
    ClusterRenderOutput output;
    uint32_t framesToConverge = 0;
    bool converged = false; // false: maxFrames ran out
    std::vector<ResidencyStats> frames;
    std::vector<std::chrono::steady_clock::time_point> frameEnds; // each frame's end (collected)
    std::vector<double> frameGpuMs;                               // each frame's GPU time (its "frame" pass)
    std::vector<ImageRGBA8> frameImages;                          // readEveryFrame: each frame's image
  };
  Result<Converged> renderConverged(const ClusterRenderSettings& settings, uint32_t maxFrames = 256,
                                    bool readEveryFrame = false);
  bool hasResidency() const;

  // Frames in flight. record() writes `slot`'s frame data and records the whole frame into the
  // caller's command buffer (nothing is submitted); the caller submits it with a fence of its own
  // and, once that fence signalled, calls collect(slot) for the frame's stats and pass times
  // (image and ownedClusters stay empty: the image is colorTarget()). Slots are 0..
  // kMaxFramesInFlight - 1; a slot is reused only after its frame completed. Frames must run on
  // one queue in the order recorded: they share GPU scratch, which each frame's first barrier
  // orders after everything submitted before it. A size change recreates the targets and retires
  // the old ones until the frames using them completed (no device wait). Mixed frames may be in
  // flight too: the surfel stage keeps its frame data and counters per slot as well. Errors
  // (settings) record nothing.
  Status record(VkCommandBuffer cmd, const ClusterRenderSettings& settings, uint32_t slot);
  Result<ClusterRenderOutput> collect(uint32_t slot);
  // The colour target of the last recorded frame: VK_FORMAT_R16G16B16A16_SFLOAT, linear (not
  // sRGB), alpha straight. A recorded frame leaves it in VK_IMAGE_LAYOUT_GENERAL, last written by
  // compute shaders (COMPUTE_SHADER stage, SHADER_STORAGE_WRITE access). The caller transitions it
  // for its own use after record() (e.g. to TRANSFER_SRC_OPTIMAL for a vkCmdBlitImage to a
  // swapchain image) and may leave it in any layout: the next frame discards the contents
  // (UNDEFINED -> GENERAL) after waiting for everything submitted before it. Recreated (a new
  // handle) when the render size changes.
  const gpu::Image& colorTarget() const;
  // Uploads the camera cell's cluster PVS (lod::clusterPvs over this renderer's asset instances);
  // later frames skip instances and clusters outside it (unless settings.pvsCulling is off).
  // nullptr: no PVS culling (the camera is outside every cell). Errors when the set was made for
  // another instance count.
  // No device wait: the buffers replaced here live until every slot recorded and not yet
  // collected completed (collected, or recorded again).
  Status setPvs(const lod::ClusterPvs* pvs);
  const Bounds& worldBounds() const;
  uint64_t clusterCount() const; // all DAG clusters uploaded (not per instance)

  struct Impl;

private:
  explicit ClusterRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::render
