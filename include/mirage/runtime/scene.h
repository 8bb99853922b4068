#pragma once
// runtime::Scene (docs/runtime.md): what a .mrg (cluster DAGs, surfels, materials), a scene file
// or a generated scene needs at run time, on the GPU, and one call that renders a View of it:
//   PVS cell (re-uploads the cell's cluster PVS when the eye changes cell) -> cluster LOD near ->
//   surfels far -> transparency -> resolve.
// Headless: the CLI writes its frames to files, the viewer presents them.
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mirage/asset/source.h"
#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/runtime/config.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::lod {
struct LodAsset;
}

namespace mirage::runtime {

struct SceneOptions {
  std::string input;    // .mrg, a scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]
  std::string pvs;      // optional PVS .mrg (from mirage pvs) of the scene: draw only the eye's view cell's PVS
  bool surfels = false; // draw the file's SURF chunks: alone (surfel-only file) or far from meshes (mixed)
  uint32_t grid = 1;    // cluster LOD: the instances repeated on a grid x grid layout (1..256)
  // Optional material file (TOML, mirage/shading/material_file.h) applied to the scene's meshes and
  // materials after import: its materials override the file's, its point lights are added.
  std::string materials;
  // Surfels: the order the clouds are uploaded in (fixed at open: the renderer stores it).
  render::SurfelOrder surfelOrder = render::kDefaultSurfelOrder;
  // Cluster LOD of a paged .mrg (mirage build --paged): GPU residency within this many bytes of
  // page geometry (docs/render.md, "Residency"); 0: every DAG uploaded whole.
  uint64_t gpuBudget = 0;
  // With a budget: prefetch every level of a new view's cut (render::ClusterResidencySettings::prefetch).
  bool prefetch = true;
  // With a budget: where page geometry goes to the GPU (render::ClusterResidencySettings::uploads).
  render::ClusterResidencySettings::Uploads uploads = render::ClusterResidencySettings::Uploads::Auto;
  // Cluster LOD: how the .mrg (file or URL) is read; `bandwidthBitsPerSecond` simulates a link
  // (`--bandwidth`), for the whole load or, with a budget, the on-demand pages too.
  asset::SourceOptions source;
};

// What open() chose from the input's contents.
enum class SceneKind {
  ClusterLod, // a .mrg with cluster DAGs (with --surfels and per-mesh SURF chunks: mixed)
  Forward,    // a scene file or gen: scene, every triangle drawn by the forward renderer
  Surfels,    // a surfel-only .mrg (SURF chunk) or surfel .ply
};
const char* toString(SceneKind kind);
// The kind open() would choose, from the file's name and chunk table only (cheap: callers check
// their options against it before starting the GPU). Errors: a .mrg holding only surfels (without
// SceneOptions::surfels) or only a PVS.
Result<SceneKind> sceneKind(const SceneOptions& options);

struct View {
  render::Camera camera; // clip planes derived from the scene when zero
  uint32_t width = 1920, height = 1080;
  RenderConfig config;
  bool readImage = true;   // false: no readback (benchmarks; the GPU stays busy)
  bool readLinear = false; // also the linear float image (EXR, metrics)
  // GPU residency with readImage: every frame until convergence read back and kept
  // (Frame::Residency::images; ClusterRenderer::renderConverged's readEveryFrame).
  bool readEveryFrame = false;
  // GPU residency: this view is a camera cut (render::ClusterRenderSettings::cameraCut); set it on
  // the cut's frame only. Without it a cut is told from the camera's motion (render::isCameraCut).
  bool cameraCut = false;
  // Stereo (cluster LOD, mixed and surfel scenes): the eyes are render::stereoEyes(camera, ipd),
  // one shared selection (clusters and surfel prefixes), the image (2 * width) x height with the
  // left eye left (docs/render.md, "Stereo").
  std::optional<float> stereoIpd;
  // Forward and cluster-LOD scenes: particle billboards drawn with the blended geometry, sorted
  // with it per pixel (render/particle_draw.h). Not in surfel-only scenes.
  render::ParticleDraw* particles = nullptr;
};

// Surfel renderer figures of a surfel-only frame.
struct SurfelFrameStats {
  render::SurfelRaster raster = render::SurfelRaster::Auto; // the raster that ran
  uint32_t visibleInstances = 0;
  uint32_t fadingInstances = 0;
};

// Forward renderer figures: what was drawn (the PVS-restricted scene with a PVS).
struct ForwardFrameStats {
  render::FrameStats stats; // draw calls, pipeline statistics
  uint64_t triangles = 0;   // triangles of the drawn scene (all instances)
  uint64_t instances = 0;
};

struct Frame {
  ImageRGBA8 srgb;                      // empty unless View::readImage
  ImageF32 linear;                      // View::readLinear
  std::vector<gpu::PassTime> passTimes; // GPU times; "frame" is the whole frame
  // Common counters (0 where the path has none).
  uint64_t trianglesDrawn = 0; // rasterized (cluster LOD) or submitted (forward)
  uint64_t clustersDrawn = 0;
  uint64_t surfelsSplatted = 0;
  int pvsCell = -1; // the view cell whose PVS culled this frame; -1: none (no PVS, or the eye is outside)
  std::optional<render::ClusterStats> cluster; // SceneKind::ClusterLod
  std::optional<ForwardFrameStats> forward;    // SceneKind::Forward
  std::optional<SurfelFrameStats> surfels;     // SceneKind::Surfels
  // GPU residency (SceneOptions::gpuBudget) of a frame read back (View::readImage): the frames
  // rendered until the residency was stable, this one last (ClusterRenderer::renderConverged).
  struct Residency {
    uint32_t framesToConverge = 0;
    bool converged = false;
    std::vector<render::ResidencyStats> frames;
    std::vector<std::chrono::steady_clock::time_point> frameEnds; // each frame's end
    std::vector<double> frameGpuMs;                               // each frame's GPU time
    std::vector<ImageRGBA8> images;                               // View::readEveryFrame: each frame's image
  };
  std::optional<Residency> residency;
};

// Figures for reports.
struct SceneInfo {
  uint64_t sourceTriangles = 0; // cluster LOD: input triangles over instances; forward: the scene's
  uint64_t instances = 0;
  uint64_t clusters = 0;       // cluster LOD: DAG clusters uploaded (not per instance)
  uint64_t surfels = 0;        // surfels stored (surfel-only scenes and mixed ones)
  double loadSeconds = 0;      // reading (and importing or generating) the input, placing the grid
  bool blendMaterials = false; // some material is alpha BLEND (a transparency pass runs)
};

// The PVS state of a scene opened with SceneOptions::pvs.
struct PvsState {
  bool active = false; // a PVS was given
  int cell = -2;       // the cell in use: -2 none chosen yet, -1 the eye is in no cell
  size_t cells = 0;
  size_t cellTriangles = 0;      // triangles of the cell's PVS
  uint32_t visibleInstances = 0; // cluster LOD: instances with a visible cluster
  uint64_t visibleClusters = 0;  // cluster LOD: (instance, cluster) pairs visible
  uint64_t bytes = 0;            // cluster LOD: the cell's cluster PVS as uploaded
  double milliseconds = 0.0;     // cluster LOD: time to make it
};

class Scene {
public:
  // Reads the input, checks it, uploads it. Errors are one line naming the file.
  static Result<std::unique_ptr<Scene>> open(gpu::Context& context, const SceneOptions& options);
  ~Scene();

  // One frame. The config is validated first (validate()).
  Result<Frame> render(const View& view);

  // Frames in flight (docs/runtime.md "Frames in flight"), for every kind of scene, with a PVS too.
  // record() selects the eye's PVS cell and records the whole frame into the caller's command
  // buffer (nothing is submitted; View::readImage / readLinear are ignored: the image is
  // colorTarget()). The caller submits it on the context's queue with a fence of its own and,
  // once that fence signalled, collect(slot) gives the frame's pass times and counters (no image).
  // Slots are 0..render::kMaxFramesInFlight - 1; a slot is reused only after its frame completed,
  // frames run on one queue in the order recorded. render() uses slot 0: call it only with no
  // recorded frame in flight. A PVS cell change keeps the replaced cluster PVS buffers (forward:
  // visible triangles) alive until every slot that may read them completed (no device wait); a
  // size change recreates the targets and retires the old ones the same way.
  Status record(VkCommandBuffer cmd, const View& view, uint32_t slot);
  Result<Frame> collect(uint32_t slot);
  // The colour target of the last recorded frame (never null):
  // VK_FORMAT_R16G16B16A16_SFLOAT, linear (not sRGB), alpha straight, View's size (stereo: 2 *
  // width, left eye left). record() leaves it in VK_IMAGE_LAYOUT_GENERAL, its writes visible to a
  // barrier from compute shaders (COMPUTE_SHADER stage, SHADER_STORAGE_WRITE access); the caller transitions it for its
  // blit or copy in the same command buffer and may leave it in any layout. A new handle after a
  // size change.
  const gpu::Image* colorTarget() const;

  // With a PVS: makes the view cell holding `eye` current (cluster LOD: uploads its cluster PVS;
  // forward: draws only its PVS triangles, an error when the eye is in no cell). True when the
  // cell changed. render() calls it; callers that report the cell call it first.
  Result<bool> selectPvsCell(glm::vec3 eye);

  SceneKind kind() const;
  const Bounds& bounds() const; // world bounds of everything drawn (after the grid)
  const SceneInfo& info() const;
  const PvsState& pvs() const;
  const SceneOptions& options() const;
  gpu::Context& context() const;
  // Cluster LOD: the loaded asset (benchmark baselines draw it with the forward renderer); else null.
  const lod::LodAsset* lodAsset() const;
  // With a PVS: its view cells and per-cell triangles; else null.
  const vis::PvsData* pvsData() const;

  struct Impl;

private:
  explicit Scene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::runtime
