// Debug views of the cluster-LOD renderer (docs/render.md, "Debug views"): the colour of each view,
// written once for the debug resolve (cluster_debug_resolve.comp) and for the tests and tools that
// map a colour back to what it shows. Compiled as GLSL and as C++ (glm), like lod_error.h.
#ifndef MIRAGE_SHADERIO_DEBUG_VIEW_H
#define MIRAGE_SHADERIO_DEBUG_VIEW_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using glm::clamp;
using glm::log2;
using glm::max;
using glm::mix;
using glm::pow;
using glm::step;
using vec3 = glm::vec3;
using uint = uint32_t;
#define MIRAGE_SHARED inline
#else
#define MIRAGE_SHARED
#endif

// ClusterFrame::debugView (render::DebugView's numbers).
#define MIRAGE_DEBUG_VIEW_NONE 0u
#define MIRAGE_DEBUG_VIEW_CLUSTERS 1u
#define MIRAGE_DEBUG_VIEW_LOD 2u
#define MIRAGE_DEBUG_VIEW_DENSITY 3u
#define MIRAGE_DEBUG_VIEW_OVERDRAW 4u

// Density view: log2 of triangles per pixel shown, [min, max]; values outside are clamped.
#define MIRAGE_DEBUG_DENSITY_LOG2_MIN -8.0f
#define MIRAGE_DEBUG_DENSITY_LOG2_MAX 4.0f

// Clusters view: a stable colour per (instance, global cluster id), the same in every frame and
// backend, whatever the cluster's slot in the visible list. A 32-bit integer hash (lowbias32,
// Wellons) spreads neighbouring ids over the whole colour cube; channels stay in 0.2..1 so no
// cluster is near black.
MIRAGE_SHARED vec3 debugClusterColor(uint instance, uint cluster) {
  uint h = cluster * 0x9e3779b1u + instance * 0x85ebca6bu + 0x27d4eb2fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return vec3(float(h & 255u), float((h >> 8) & 255u), float((h >> 16) & 255u)) * (0.8f / 255.0f) + 0.2f;
}

// A fixed ramp of ten steps, 9 and above white: the LOD view's colour of DAG level `step` (0 is the
// full-detail level) and the overdraw view's colour of `step + 1` triangles per pixel.
MIRAGE_SHARED vec3 debugStepColor(uint step) {
  if (step == 0u) return vec3(0.10f, 0.15f, 0.90f); // blue
  if (step == 1u) return vec3(0.00f, 0.70f, 1.00f); // sky
  if (step == 2u) return vec3(0.00f, 0.80f, 0.40f); // green
  if (step == 3u) return vec3(0.55f, 0.90f, 0.00f); // lime
  if (step == 4u) return vec3(1.00f, 0.90f, 0.00f); // yellow
  if (step == 5u) return vec3(1.00f, 0.55f, 0.00f); // orange
  if (step == 6u) return vec3(1.00f, 0.10f, 0.00f); // red
  if (step == 7u) return vec3(0.90f, 0.00f, 0.60f); // magenta
  if (step == 8u) return vec3(0.55f, 0.20f, 0.90f); // violet
  return vec3(1.0f);                                // white
}

// Density view: triangles per pixel (1 / the triangle's projected area in pixels) on a log2 ramp.
// Below 1 triangle per pixel cool colours (dark blue at 1/256, cyan at 1/16, green just below 1);
// from 1 triangle per pixel warm ones (yellow at 1, red at 4, white from 16). The jump from green
// to yellow marks 1 triangle per pixel.
MIRAGE_SHARED vec3 debugDensityColor(float trianglesPerPixel) {
  float l = clamp(log2(max(trianglesPerPixel, 1e-30f)), MIRAGE_DEBUG_DENSITY_LOG2_MIN, MIRAGE_DEBUG_DENSITY_LOG2_MAX);
  if (l < -4.0f) return mix(vec3(0.05f, 0.05f, 0.40f), vec3(0.00f, 0.70f, 0.90f), (l + 8.0f) / 4.0f);
  if (l < 0.0f) return mix(vec3(0.00f, 0.70f, 0.90f), vec3(0.10f, 0.75f, 0.10f), (l + 4.0f) / 4.0f);
  if (l < 2.0f) return mix(vec3(1.00f, 1.00f, 0.00f), vec3(1.00f, 0.00f, 0.00f), l / 2.0f);
  return mix(vec3(1.00f, 0.00f, 0.00f), vec3(1.00f, 1.00f, 1.00f), (l - 2.0f) / 2.0f);
}

// The colours above are display (sRGB) values, as a PNG shows them; the debug resolve writes this
// linear value, which the sRGB encoding of the output turns back into them.
MIRAGE_SHARED vec3 debugToLinear(vec3 srgb) {
  return mix(srgb / 12.92f, pow((srgb + 0.055f) / 1.055f, vec3(2.4f)), step(vec3(0.04045f), srgb));
}

#undef MIRAGE_SHARED
#ifdef __cplusplus
} // namespace mirage::shaderio
#endif

#endif
