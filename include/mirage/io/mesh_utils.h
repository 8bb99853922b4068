#pragma once
// Mesh post-processing shared by the importers (and usable by generators): normals, bounds, welding, validation.
#include <string>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

// Area-weighted vertex normals (the cross product's length is twice the triangle area, so summing unnormalised
// face normals weights by area). Vertices touched only by degenerate triangles get +Z so normals are always unit.
void computeNormals(Mesh& mesh);

// Object-space bounds of the positions.
void computeBounds(Mesh& mesh);

// Merge vertices bit-equal in position and every present attribute (the same result as meshopt's
// generateVertexRemapMulti, found via hash buckets, which is faster on huge meshes), then drop vertices no
// triangle uses. Survivors keep their relative order. Triangles are kept as they are (degenerate ones included)
// so triangle counts never change.
void weldMesh(Mesh& mesh);

// Tangents (xyz + handedness w) from positions, normals and uv0 (per-triangle UV derivatives, accumulated and
// Gram-Schmidt orthogonalised). Leaves tangents empty when the mesh has no uv0 or normals.
void computeTangents(Mesh& mesh);

// Check a mesh: non-empty, index count a multiple of 3, indices in range, attribute arrays empty or sized like
// positions, then validateFinite. The error names `file` and the mesh.
Status validateMesh(const Mesh& mesh, const std::string& file);

// Every position, normal, tangent, texture coordinate and colour finite (the check a point cloud gets too).
Status validateFinite(const Mesh& mesh, const std::string& file);

} // namespace mirage::io
