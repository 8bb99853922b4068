#pragma once
// `mirage render scene.mrg` and `mirage bench render scene.mrg`: the GPU-driven cluster-LOD
// renderer on baked assets (the forward path keeps every other input).
#include <string>

namespace mirage::cli {

struct LodRenderRequest {
  std::string input;  // .mrg
  std::string output; // .png (render only)
  std::string exr;    // optional linear image (render only)
  std::string camera; // empty: auto 3/4 view
  std::string path;   // camera path: cameras.json or orbit:N (render: one image per camera)
  std::string size = "1920x1080";
  std::string device;
  std::string raster = "auto"; // auto | mesh | indirect | compute; bench: "all" = every supported one
  float tau = 1.0f;            // LOD threshold in pixels
  uint32_t grid = 1;           // >1: the scene's instances repeated on a grid x grid layout (benchmark scenes)
  int frames = 1;              // render: --repeat; bench: --frames (the first is a warm-up)
  bool stats = false;
  bool json = false;
  bool baselines = false; // bench: also brute force and a discrete LOD chain (forward renderer)
};

bool isLodAssetPath(const std::string& input);
void runLodRender(const LodRenderRequest& request);
void runLodBench(const LodRenderRequest& request);

} // namespace mirage::cli
