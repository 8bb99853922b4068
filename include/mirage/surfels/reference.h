#pragma once
// CPU reference sampler and quality metrics for Blue Surfels (no Vulkan).
#include <cstdint>
#include <vector>

#include "mirage/surfels/surfel.h"

namespace mirage::surfels {

// The deterministic first sample both samplers use: the texel farthest from the capture centre
// (ties: the larger global texel index).
uint32_t firstSampleTexel(const GBufferTexels& texels);

// Exact greedy farthest-point ordering of the texels (kd-tree range updates, max-heap with lazy
// re-insertion): sample k is the texel farthest from samples 0..k-1, ties to the larger texel id.
// Stops after `count` samples or when every texel is a sample. radii[0] is the capture diameter.
SampleOrder farthestPointReference(const GBufferTexels& texels, uint32_t count);

struct PrefixQuality {
  uint32_t count = 0;    // prefix length N
  double radius = 0.0;   // the prefix's disc radius: radii[N-1]
  double rMin = 0.0;     // half the smallest nearest-neighbour distance in the prefix
  double rMax = 0.0;     // sqrt(A / (2·sqrt(3)·N)): hexagonal packing radius of N discs on area A
  double rho = 0.0;      // normalized Poisson radius rMin / rMax
  double coverage = 0.0; // fraction of texels within `radius` of some prefix sample
};

// Metrics of the first `count` samples of `order` (A = texels.totalArea).
PrefixQuality measurePrefix(const GBufferTexels& texels, const SampleOrder& order, uint32_t count);

} // namespace mirage::surfels
