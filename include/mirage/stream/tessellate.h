#pragma once
// Tessellation of large triangles at scene load (docs/stream.md, "Tessellation"). A patch gets at
// most a 2^MIRAGE_ATLAS_MAX_BLOCK_LOG2 = 128-texel block, so a triangle hundreds of pixels across
// would be magnified; before patches are built, every triangle with an edge longer than a world
// length L is split, longest edge first, until none is. An edge of length l > L is split into
// n = ceil(l / L) pieces, recursively: at the fraction floor(n / 2) / n of the way from its
// lexicographically smaller endpoint. That depends on the edge alone, so the two triangles sharing
// an edge split it at the same points (bitwise, whichever way each reads it, across seams of split
// vertices too) and the refined mesh has no T-junctions. Attributes (normal, tangent, uv, colour)
// of a new vertex are interpolated along its edge: barycentric interpolation over the source
// triangle, so the refined mesh shades and rasterizes as the source does. Materials are per mesh.
#include <cstdint>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::stream {

// The longest patch edge by default: the scene's bounding-box diagonal over this. The rule
// (docs/stream.md, "Tessellation"): an edge of L world units seen from distance d on a viewport H
// pixels high with vertical field of view fov covers L H / (2 d tan(fov / 2)) pixels, and the
// largest block spans 127 texels along it, so one texel per pixel holds down to
// d_min = L H / (254 tan(fov / 2)). At 1920x1080 and fov 60 degrees, L = diagonal / 64 gives
// d_min = 11.5 % of the diagonal (Sponza: 4.8 m). Finer defaults cost patches on every scene, also
// where no view comes close (gen:city:2 holds 2.8x its triangles at diagonal / 64, 8.5x at / 128,
// 29x at / 256); a scene seen from closer than d_min sets maxPatchEdge from its own d_min.
constexpr float kPatchEdgeDivisions = 64.0f;

struct TessellationConfig {
  // Longest triangle edge the patches may have, in world units. 0: the scene's bounding-box
  // diagonal / kPatchEdgeDivisions. +infinity: no tessellation.
  float maxPatchEdge = 0.0f;
  // Most instanced triangles (what the server draws and numbers) the refined scene may hold; a scene
  // that would hold more is refused while it is refined, before memory grows past this bound.
  uint64_t maxTriangles = uint64_t(1) << 25;
};

// The world length L the scene's triangle edges are split to (+infinity: none are).
float patchEdgeLength(const Scene& scene, const TessellationConfig& config);

// `mesh` with every triangle that has an edge longer than maxEdge (object space) split, longest edge
// first, until no edge is longer (an edge whose split point rounds onto an endpoint is left as it
// is: float precision). Source vertices keep their indices; new vertices follow, one per
// split edge of the mesh (edges shared by index share their new vertices). Each source triangle's
// pieces are consecutive and keep its winding; sourceTriangle (optional) receives each output
// triangle's source triangle. Errors: a triangle to split with a non-finite position, more than
// maxTriangles triangles.
Result<Mesh> refineMesh(const Mesh& mesh, float maxEdge, uint64_t maxTriangles,
                        std::vector<uint32_t>* sourceTriangle = nullptr);

struct TessellationStats {
  float maxPatchEdge = 0.0f;    // world units; +infinity: no tessellation
  uint64_t trianglesBefore = 0; // instanced
  uint64_t trianglesAfter = 0;  // instanced
};

// Refines every instanced mesh of the scene in place to patchEdgeLength in world units (each mesh
// in its object space: L / the largest maxAxisScale of its instances). Errors (the scene is then
// left partly refined: the caller drops it): a bad configuration, a refined scene over
// config.maxTriangles.
Result<TessellationStats> tessellateScene(Scene& scene, const TessellationConfig& config);

} // namespace mirage::stream
