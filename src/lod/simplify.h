#pragma once
// Quadric-error half-edge-collapse simplifier with explicit per-vertex locks, written for the DAG
// builder because meshoptimizer 0.18 can only lock *every* open-border vertex (which also freezes
// the mesh's own border) and scans its whole vertex buffer per call. See docs/lod.md.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace mirage::lod::detail {

struct SimplifyMesh {
  std::vector<glm::vec3> positions; // compact, welded: topology is decided on these
  std::vector<uint8_t> locked;      // per position: 1 = must not move (group border)
  std::vector<uint32_t> corners;    // position id per triangle corner, 3 per triangle
  std::vector<uint32_t> attributes; // carried attribute-vertex id per corner (never inspected)
};

// Collapses edges (the removed vertex moves onto a kept neighbour, so no new positions or
// attributes appear) in order of quadric error until at most targetTriangles remain or no legal
// collapse is left. Locked vertices never move; an unlocked open-border vertex only slides along
// its border; non-manifold vertices stay. Rewrites corners/attributes to the surviving triangles
// and returns the error: the square root of the largest area-normalised quadric cost collapsed,
// a distance in position units.
float simplifyLocked(SimplifyMesh& mesh, size_t targetTriangles);

} // namespace mirage::lod::detail
