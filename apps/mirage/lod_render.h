#pragma once
// `mirage render scene.mrg` and `mirage bench render scene.mrg`: the GPU-driven cluster-LOD
// renderer on baked assets (the forward path keeps every other input).
#include <string>

#include "mirage/render/cluster_renderer.h"

namespace CLI {
class App;
}

namespace mirage::cli {

// Culling and raster-split options of the cluster renderer, shared by render and bench render.
struct LodCullOptions {
  float hybridThreshold = 16.0f;  // --hybrid-threshold: estimated triangle edge (px) from which clusters go to hardware
  std::string occlusion = "off";  // --occlusion on|off (bench: also "both": each backend with and without)
  std::string cones = "on";       // --cones on|off: normal-cone back-face culling
  std::string selection = "auto"; // --selection auto|flat|hierarchy: how the LOD cut is found
  // --blend-raster auto|compute|hybrid|hardware: how BLEND clusters are rasterized (bench: also
  // "all": each of compute, hybrid and hardware the device has, per opaque backend)
  std::string blendRaster = "auto";
  bool isDefault() const {
    return hybridThreshold == 16.0f && occlusion == "off" && cones == "on" && selection == "auto" &&
           blendRaster == "auto";
  }
};
void addLodCullOptions(CLI::App& command, LodCullOptions& options, bool bench);

struct LodRenderRequest {
  std::string input;  // .mrg
  std::string output; // .png (render only)
  std::string exr;    // optional linear image (render only)
  std::string camera; // empty: auto 3/4 view
  std::string path;   // camera path: cameras.json or orbit:N (render: one image per camera)
  std::string size = "1920x1080";
  std::string device;
  std::string raster = "auto"; // auto | mesh | indirect | compute | hybrid; bench: "all" = every supported one
  float tau = render::kDefaultTauPixels; // LOD threshold in pixels
  uint32_t grid = 1;     // >1: the scene's instances repeated on a grid x grid layout (benchmark scenes)
  int frames = 1;        // render: --repeat; bench: --frames (the first is a warm-up)
  double warmupMs = 0.0; // bench: the warm-up frame repeats for this long (GPU clock)
  bool stats = false;
  bool json = false;
  bool baselines = false; // bench: also brute force and a discrete LOD chain (forward renderer)
  LodCullOptions cull;
  bool surfels = false;    // --surfels on a .mrg with DAGs and per-mesh SURF chunks: meshes near, surfels far
  float surfelSize = 2.0f; // --surfel-size
  // --pvs pvs.mrg (a triangle PVS of the scene the asset was built from): cull with the cluster PVS
  // of the camera's view cell. Bench: every frame timed with and without it; with no --camera or
  // --path, cameras at every cell's centre looking four ways.
  std::string pvs;
};

bool isLodAssetPath(const std::string& input);
// A .mrg holding cluster DAGs ('CDAG'): `--surfels` on it renders the mixed scene (docs/render.md).
bool mrgHasClusterDags(const std::string& input);
// Which kinds of chunk a .mrg holds (all false when it cannot be opened: the loader reports why).
struct MrgContents {
  bool clusterDags = false, surfels = false, pvs = false, scene = false;
};
MrgContents mrgContents(const std::string& input);
void runLodRender(const LodRenderRequest& request);
void runLodBench(const LodRenderRequest& request);

} // namespace mirage::cli
