#pragma once
// The baseline renderer: forward shading with dynamic rendering, glTF metallic-roughness, one
// directional key light plus hemisphere ambient, tangent-space normal maps, alpha MASK, BLEND drawn
// after opaque by order-independent transparency (render/oit.h; docs/render.md "Transparency").
// Depth: 32-bit float, reverse-Z. Headless: renders to an offscreen target and reads it back.
#include <memory>
#include <optional>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/render/oit.h"

namespace mirage::render {

class ParticleDraw;

struct RenderSettings {
  uint32_t width = 1920;
  uint32_t height = 1080;
  Camera camera;                                // clip planes derived from the scene when zero
  glm::vec3 lightDirection{0.35f, 1.0f, 0.45f}; // towards the light, world space (normalized on use)
  float lightIntensity = 2.6f;
  glm::vec3 skyAmbient{0.32f, 0.34f, 0.38f};
  glm::vec3 groundAmbient{0.12f, 0.11f, 0.10f};
  glm::vec4 background{0.02f, 0.022f, 0.026f, 1.0f}; // linear RGB
  bool readLinear = false;                           // also return the linear float image (EXR, metrics)
  // false: no image readback (empty images). Benchmarks: converting a 1080p image on the CPU leaves the
  // GPU idle for tens of ms per frame, the driver lowers its clocks, and later frames time several
  // times slower (measured on the H200).
  bool readImage = true;
};

struct FrameStats {
  std::vector<gpu::PassTime> passTimes; // GPU times from timestamp queries
  gpu::PipelineStatistics pipeline;     // zero where the device has no pipeline-statistics queries
  uint64_t drawCalls = 0;
  uint64_t trianglesSubmitted = 0;
  OitStats oit; // linked-list transparency (zero in the other modes and without BLEND materials)
};

struct RenderOutput {
  ImageRGBA8 srgb; // 8-bit sRGB, what PNG files hold
  ImageF32 linear; // linear RGBA, filled when RenderSettings::readLinear
  FrameStats stats;
};

// A forward frame: the common settings, and for stereo (docs/render.md, "Stereo") the distance
// between the eyes: stereoEyes(base.camera, ipd) (camera.h) drawn left|right into one target of
// 2 * base.width x base.height, each eye with its own viewport and clip planes.
struct ForwardRenderSettings {
  RenderSettings base;
  std::optional<float> stereoIpd;
  OitMode oit = OitMode::LinkedList; // how BLEND materials are drawn
  // Linked lists: the node pool holds this many fragments per target pixel on average (1..64;
  // capped by maxStorageBufferRange); fragments past it are dropped and counted.
  uint32_t oitNodesPerPixel = 8;
  // Particle billboards drawn with the blended geometry (render/particle_draw.h); null: none.
  ParticleDraw* particles = nullptr;
};

class ForwardRenderer {
public:
  // Uploads the scene's geometry, materials and textures. The scene may be freed afterwards.
  static Result<std::unique_ptr<ForwardRenderer>> create(gpu::Context& context, const Scene& scene);
  ~ForwardRenderer();

  // One frame, synchronously: record + submit and wait + collect, then the image read back as the
  // settings ask. Call it only with no recorded frame in flight (it uses slot 0).
  Result<RenderOutput> render(const ForwardRenderSettings& settings);
  Result<RenderOutput> render(const RenderSettings& settings) { return render(ForwardRenderSettings{settings, {}}); }

  // Frames in flight, as ClusterRenderer's: record() writes `slot`'s frame data (cameras, the
  // blend order) and records the frame into the caller's command buffer; the caller submits it
  // with a fence of its own and, once that fence signalled, collect(slot) gives the stats and
  // pass times (no image: the image is colorTarget()). Slots are 0..kMaxFramesInFlight - 1; a
  // slot is reused only after its frame completed. Frames run on one queue in the order recorded:
  // they share the targets, which each frame's first barrier orders after everything submitted
  // before it. A size change retires the old targets until the frames using them completed.
  // Errors (settings) record nothing.
  Status record(VkCommandBuffer cmd, const ForwardRenderSettings& settings, uint32_t slot);
  Result<RenderOutput> collect(uint32_t slot);
  // The colour target of the last recorded frame: VK_FORMAT_R16G16B16A16_SFLOAT, linear, as
  // ClusterRenderer::colorTarget(): left in VK_IMAGE_LAYOUT_GENERAL, its writes visible to compute
  // shaders (a following barrier from COMPUTE_SHADER / SHADER_STORAGE_WRITE chains after them).
  // The next frame discards the contents. Recreated (a new handle) when the size changes.
  const gpu::Image& colorTarget() const;
  const Bounds& worldBounds() const { return worldBounds_; }

  // Draw only these triangles of the scene from the next recorded frame on (a view cell's PVS):
  // sorted global IDs, instance-major over the scene's instances, each instance's mesh triangles
  // in index order (vis::triangleOffsets). nullptr draws the whole scene again. The next frame
  // recorded copies the listed triangles' indices on the GPU; the buffers replaced here live until
  // every slot recorded and not yet collected completed (no device wait). Errors (an ID outside
  // the scene, unsorted IDs) change nothing.
  Status setVisibleTriangles(const std::vector<uint32_t>* sortedIds);

  struct Impl;

private:
  explicit ForwardRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  Bounds worldBounds_;
};

// Largest width or height accepted (the Vulkan guarantee for 2D images).
constexpr uint32_t kMaxRenderDimension = 16384;

} // namespace mirage::render
