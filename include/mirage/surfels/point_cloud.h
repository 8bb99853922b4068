#pragma once
// Point clouds (a scanner's PLY: vertices with normals and colours, no faces) as sampler input.
// Two paths: the exact one (pointCloudTexels: each point becomes one "texel" and the exact CPU
// farthest-point order, reference.h, runs on them) and the GPU one (capturePointCloud in
// capture.h splats every point as an oriented disc into the same G-buffers as a mesh, and the
// GPU sampler runs unchanged). ScanPoints is what both start from.
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/surfels/surfel.h"

namespace mirage::surfels {

// Neighbours of the spacing estimate: r_k, the distance to the k-th nearest other point.
constexpr uint32_t kPointNeighbours = 16;

// The points of every instance in world space, with what each path needs per point.
struct ScanPoints {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals; // unit; estimated (unoriented) when the scan has none
  std::vector<uint32_t> colors;   // linear RGBA8; white where the scan has none
  std::vector<float> spacing;     // r_k per point (k = kPointNeighbours)
  bool hasNormals = false;        // every point came with a normal (oriented: the GPU capture culls back faces)

  size_t size() const { return positions.size(); }
};

// Scans without normals get them from their neighbourhood: the direction of least spread (PCA) of
// the points within r_k. Their sign is arbitrary (nothing tells inside from outside), so the GPU
// capture splats such discs two-sided and turns each texel's normal towards its view.
// Errors: no points, fewer than k + 1 points, 2^32 points or more.
Result<ScanPoints> scanPoints(const Scene& scene);

// Unit eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix (a plane's normal from
// its points' covariance); +z when the matrix is a multiple of the identity.
glm::vec3 leastSpreadDirection(const glm::dmat3& covariance);

// `mirage surfels --points auto` takes the GPU path (capturePointCloud + the GPU sampler) from this
// many points on (peeling layers only with the scan's normals), when a GPU with 64-bit atomics is there; below it the
// exact CPU order. Both paths share the k-NN spacing pass, so the choice is about the sampler: the
// CPU reference grows with points × log(samples) and passes ~1 s on 2 cores at ~0.5 M points
// (docs/surfels.md), where the GPU path's fixed cost (device start, G-buffer readback and areas)
// is about that large on a real GPU; below, exactness is cheap.
constexpr size_t kAutoGpuPointCount = 500000;

// True when the scene has points but no triangles.
bool isPointCloud(const Scene& scene);

// One texel per point of every instance (world space): ids 0..N-1, unit normals (+z when a point
// has none), linear RGBA8 colours (white when none), and a surface area per point from its
// neighbourhood: π·r_k² / k with r_k the distance to the k-th nearest other point (k = 16). For
// uniformly scattered points π·r_k²·density follows Gamma(k, 1), whose mean is k: so this is the
// unbiased area per point (π·r_k² / (k − 1) would be 1/k too large). A is their sum.
// Errors: no points, or fewer than k + 1 points.
Result<GBufferTexels> pointCloudTexels(const Scene& scene);
GBufferTexels pointCloudTexels(const ScanPoints& points);

} // namespace mirage::surfels
