#pragma once
// Per-frame settings of a runtime::Scene (docs/runtime.md): every knob of the cluster-LOD, forward
// and surfel renderers that may change from one frame to the next, typed, with the renderers' own
// defaults. The CLI binds it once (apps/mirage/render_options.cpp), the viewer edits it live.
#include <optional>

#include "mirage/core/result.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/surfel_renderer.h"

namespace mirage::runtime {

// Defaults come from the renderers' settings structs: written there once.
inline const render::ClusterRenderSettings kClusterDefaults{};
inline const render::SurfelRenderSettings kSurfelDefaults{};
inline const render::ForwardRenderSettings kForwardDefaults{};

struct RenderConfig {
  // Cluster LOD (.mrg with cluster DAGs).
  float tauPixels = kClusterDefaults.tauPixels; // projected error allowed, pixels
  render::RasterBackend raster = kClusterDefaults.raster;
  render::BlendRaster blendRaster = kClusterDefaults.blendRaster;
  render::SelectionMode selection = kClusterDefaults.selection;
  render::StereoMode stereoMode = kClusterDefaults.stereoMode; // stereo views: multiview or per-eye viewports
  bool occlusionCulling = kClusterDefaults.occlusionCulling;
  bool coneCulling = kClusterDefaults.coneCulling;
  bool transparency = kClusterDefaults.transparency; // alpha BLEND materials drawn (off: opaque and MASK only)
  // How BLEND materials are drawn (--oit): auto (each renderer's default), forward scenes
  // linked-list, weighted or sorted, cluster LOD linked-list or packed.
  render::OitMode oit = render::OitMode::Auto;
  float hybridThreshold = kClusterDefaults.hybridThreshold;   // pixels
  bool leanRaster = kClusterDefaults.leanRaster;              // compute raster: small clusters by the lean kernel
  float blendQueuePixels = kClusterDefaults.blendQueuePixels; // pixels; +inf: no blend queue
  // Transparency node pool per target pixel (--oit-nodes-per-pixel); unset: each renderer's own
  // default (cluster LOD ClusterRenderSettings::oitNodesPerPixel, forward ForwardRenderSettings's).
  std::optional<uint32_t> oitNodesPerPixel;
  bool pvsCulling = kClusterDefaults.pvsCulling; // cull with the view cell's cluster PVS (if any)
  // Foveation (--fovea X,Y --fovea-radius DEG): tau grows with eccentricity from the gaze point.
  bool foveation = kClusterDefaults.foveation;
  glm::vec2 foveaGaze = kClusterDefaults.foveaGaze; // normalized screen coordinates, 0..1
  float foveaRadiusDegrees = kClusterDefaults.foveaRadiusDegrees;
  // Debug view (--debug-view): colour by cluster, DAG level, triangle density or overdraw instead of shading.
  render::DebugView debugView = kClusterDefaults.debugView;
  // Surfels (surfel-only scenes, and the far field of mixed scenes).
  float surfelSize = kSurfelDefaults.surfelSize; // diameter in pixels
  render::SurfelRaster surfelRaster = kSurfelDefaults.raster;
  bool drawSurfels = true; // mixed scenes: surfels far away (off: the meshes at every distance)
};

// Range checks, done once here: the messages name the CLI flag ("--tau must be ...").
Status validate(const RenderConfig& config);

} // namespace mirage::runtime
