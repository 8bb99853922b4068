#pragma once
// Point clouds (a scanner's PLY: vertices with normals and colours, no faces) as sampler input.
// The points already lie on the surface, so there is nothing to rasterize or to hide: each point
// becomes one "texel" and the exact farthest-point order (reference.h) runs on them directly.
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/surfels/surfel.h"

namespace mirage::surfels {

// True when the scene has points but no triangles.
bool isPointCloud(const Scene& scene);

// One texel per point of every instance (world space): ids 0..N-1, unit normals (+z when a point
// has none), linear RGBA8 colours (white when none), and a surface area per point from its
// neighbourhood: π·r_k² / k with r_k the distance to the k-th nearest other point (k = 16). For
// uniformly scattered points π·r_k²·density follows Gamma(k, 1), whose mean is k: so this is the
// unbiased area per point (π·r_k² / (k − 1) would be 1/k too large). A is their sum.
// Errors: no points, or fewer than k + 1 points.
Result<GBufferTexels> pointCloudTexels(const Scene& scene);

} // namespace mirage::surfels
