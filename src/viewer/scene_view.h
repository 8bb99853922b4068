#pragma once
// The viewer's one seam to the renderers: open a scene, render a View into a CPU sRGB image with
// its stats. Cluster-LOD assets (.mrg) go to render::ClusterRenderer (with the cell's cluster PVS
// and per-mesh surfels when asked), other scene files to render::ForwardRenderer. The shape follows
// runtime::Scene (Scene::open, Scene::render(View) -> Frame) so the viewer moves to it here only.
#include <memory>
#include <string>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"

namespace mirage::viewer {

struct SceneOptions {
  std::string path;     // .mrg (cluster LOD) or a scene file (.gltf .glb .obj .ply)
  std::string pvs;      // .mrg: a triangle PVS (mirage pvs) of the scene the asset was built from
  bool surfels = false; // .mrg: draw the per-mesh SURF chunks far away (mixed scene)
};

// What the overlay changes between frames (each maps to a renderer setting that exists).
struct ViewConfig {
  float tauPixels = render::kDefaultTauPixels;
  float surfelSize = 2.0f;
  render::RasterBackend raster = render::RasterBackend::Auto;
  bool occlusion = false; // the render command's default
  bool pvs = true;        // cull with the cell's PVS (when the scene has one)
  bool surfels = true;    // draw the surfels (when the scene has them)
  bool flagBackFaces = false;
};

struct View {
  render::Camera camera; // clip planes derived from the scene when zero
  uint32_t width = 1280, height = 720;
  ViewConfig config;
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
  // Cheap checks of the options and the input's name and kind (no GPU; before the window system).
  static Status check(const SceneOptions& options);
  // Reads the input, checks it, uploads it. Errors are one line naming the file.
  static Result<std::unique_ptr<SceneView>> open(gpu::Context& context, const SceneOptions& options);
  ~SceneView();
  Result<Frame> render(const View& view);

  const Bounds& bounds() const;
  bool clusterLod() const;
  bool hasSurfels() const;
  bool hasPvs() const;

  struct Impl;

private:
  explicit SceneView(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::viewer
