#pragma once
// Blue Surfels data: the G-buffer texels the samplers choose from, a progressive sample order over
// them, and the 16-byte surfel cloud built from that order. No Vulkan here (the capture and GPU
// sampler live in capture.h and gpu_sampler.h).
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/octahedral.h"
#include "mirage/core/scene.h"
#include "mirage/shaderio/surfels.h"

namespace mirage::surfels {

using shaderio::Surfel;

// The valid texels of a V-view G-buffer, in increasing global texel index (view, row, column).
struct GBufferTexels {
  uint32_t resolution = 0;           // G-buffer width = height
  uint32_t viewCount = 0;            // G-buffer views: capture directions × depth-peeling layers
  uint32_t layers = 1;               // depth-peeling layers; view w has direction w % (viewCount / layers)
  float texelSize = 0.0f;            // world size of a texel side (orthographic: the same everywhere)
  glm::vec3 center{0.0f};            // centre of the capture sphere
  float sphereRadius = 0.0f;         // radius of the capture sphere
  std::vector<glm::vec3> directions; // per view: unit direction from the scene towards the camera
  std::vector<uint32_t> ids;         // global texel index: view * resolution² + y * resolution + x
  std::vector<glm::vec3> positions;  // world position
  std::vector<glm::vec3> normals;    // unit normal, facing the view that saw it
  std::vector<uint32_t> colors;      // linear RGBA8 base colour
  std::vector<float> areas;          // surface area this texel stands for, deduplicated across views
  double totalArea = 0.0;            // sum of areas: the sampled area A of the quality metrics

  size_t size() const { return positions.size(); }
  // Compact index of a global texel index, or UINT32_MAX when that texel saw nothing.
  uint32_t compactIndex(uint32_t globalId) const;
};

// A progressive order over texels: every prefix is a farthest-point (blue-noise) sampling.
struct SampleOrder {
  std::vector<uint32_t> texels; // compact texel indices, in order
  std::vector<float> radii;     // radii[k]: distance of sample k to samples 0..k-1 (non-increasing)
};

// The output: quantized surfels in progressive order plus what a renderer needs beside them.
struct SurfelCloud {
  Bounds box;                          // quantization box of the positions
  std::vector<Surfel> surfels;         // progressive order
  std::vector<float> radii;            // per prefix length k: radii[k-1] is the Poisson radius of the prefix
  uint32_t referenceCount = 0;         // N_ref = min(1000, N)
  float referenceMeanSpacing = 0.0f;   // mean nearest-neighbour distance among the first N_ref surfels
  float referenceMedianSpacing = 0.0f; // median of the same distances

  size_t size() const { return surfels.size(); }
};

// Packing (exact inverses up to quantization; tests check the error bounds).
Surfel packSurfel(const Bounds& box, glm::vec3 position, glm::vec3 normal, uint32_t color);
glm::vec3 surfelPosition(const Bounds& box, const Surfel& s);
glm::vec3 surfelNormal(const Surfel& s);
using mirage::decodeOctahedral; // mirage/core/octahedral.h
using mirage::encodeOctahedral;

// Surfels for `order` over `texels`, with the N_ref spacing statistics.
SurfelCloud buildSurfelCloud(const GBufferTexels& texels, const SampleOrder& order);

} // namespace mirage::surfels
