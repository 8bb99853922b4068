#pragma once
// The baseline renderer: forward shading with dynamic rendering, glTF metallic-roughness, one
// directional key light plus hemisphere ambient, tangent-space normal maps, alpha MASK, BLEND drawn
// after opaque sorted back to front. Depth: 32-bit float, reverse-Z. Headless: renders to an
// offscreen target and reads it back.
#include <memory>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"

namespace mirage::render {

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
};

struct RenderOutput {
  ImageRGBA8 srgb; // 8-bit sRGB, what PNG files hold
  ImageF32 linear; // linear RGBA, filled when RenderSettings::readLinear
  FrameStats stats;
};

class ForwardRenderer {
public:
  // Uploads the scene's geometry, materials and textures. The scene may be freed afterwards.
  static Result<std::unique_ptr<ForwardRenderer>> create(gpu::Context& context, const Scene& scene);
  ~ForwardRenderer();

  Result<RenderOutput> render(const RenderSettings& settings);
  const Bounds& worldBounds() const { return worldBounds_; }

  struct Impl;

private:
  explicit ForwardRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  Bounds worldBounds_;
};

// Largest width or height accepted (the Vulkan guarantee for 2D images).
constexpr uint32_t kMaxRenderDimension = 16384;

} // namespace mirage::render
