#pragma once
// The viewer's one seam to the renderers: runtime::Scene (docs/runtime.md) opens the scene and
// renders a View into a CPU sRGB image with its stats; this file adds the viewer's checks and the
// figures the overlay shows.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/config.h"
#include "mirage/runtime/scene.h"

namespace mirage::viewer {

struct SceneOptions {
  std::string path;       // .mrg, a scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]
  std::string pvs;        // .mrg: a triangle PVS (mirage pvs) of the scene the asset was built from
  bool surfels = false;   // .mrg: its SURF chunks (alone, or far from the meshes)
  std::string materials;  // material file (TOML): runtime::SceneOptions::materials
  uint64_t gpuBudget = 0; // runtime::SceneOptions::gpuBudget
  uint64_t bandwidth = 0; // bits per second: runtime::SceneOptions::source
};

// What the overlay changes between frames: the runtime's per-frame settings, its defaults.
using ViewConfig = runtime::RenderConfig;

struct View {
  render::Camera camera;               // clip planes derived from the scene when zero
  uint32_t width = 1280, height = 720; // per eye with stereo
  ViewConfig config;
  std::optional<float> stereoIpd; // both eyes side by side: the image is (2 * width) x height
};

struct FrameStats {
  std::vector<gpu::PassTime> passTimes;
  uint64_t triangles = 0; // rasterized (cluster LOD) or submitted (forward)
  uint64_t clusters = 0;  // drawn; 0 on the forward path
  uint64_t surfels = 0;   // splatted
  int cell = -2;          // view cell of the camera: -2 no PVS, -1 outside every cell
};

struct Frame {
  ImageRGBA8 srgb;
  FrameStats stats;
};

class SceneView {
public:
  // Cheap checks of the options; the input's kind (no GPU; before the window system starts).
  static Result<runtime::SceneKind> check(const SceneOptions& options);
  // Reads the input, checks it, uploads it. Errors are one line naming the file.
  static Result<std::unique_ptr<SceneView>> open(gpu::Context& context, const SceneOptions& options);
  ~SceneView();
  Result<Frame> render(const View& view);
  // Frames in flight (runtime::Scene::record / collect): the frame is recorded into the swapchain
  // frame's command buffer, its image is colorTarget(), its stats come from collect(slot) once the
  // slot's fence signalled.
  Status record(VkCommandBuffer cmd, const View& view, uint32_t slot);
  Result<FrameStats> collect(uint32_t slot);
  const gpu::Image* colorTarget() const;

  const Bounds& bounds() const;
  bool clusterLod() const;
  bool hasSurfels() const;
  bool hasPvs() const;
  bool hasBlend() const; // cluster LOD with alpha BLEND materials
  bool mixed() const;    // cluster LOD with surfels far away

private:
  explicit SceneView(std::unique_ptr<runtime::Scene> scene);
  std::unique_ptr<runtime::Scene> scene_;
};

} // namespace mirage::viewer
