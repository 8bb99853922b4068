#pragma once
// Generated meshes and a tiny ASCII PLY reader for the LOD tests (the real importer lives in io).
#include <cstdint>
#include <filesystem>
#include <optional>

#include "mirage/core/scene.h"

namespace mirage::lodtest {

// Closed, bumpy icosphere: 20 * 4^subdivisions triangles, shared vertices.
Mesh makeBlob(uint32_t subdivisions, uint32_t seed);
// Open noisy heightfield over an n x n grid of quads (2 n^2 triangles).
Mesh makeTerrain(uint32_t n, uint32_t seed);
// makeBlob with vertices split into 6 UV charts (cube-map projection): positions are duplicated
// along chart seams with different UVs and normals, so seams carry 2 or 3 wedges per position.
Mesh makeSeamBlob(uint32_t subdivisions, uint32_t seed);
// A random small soup on a jittered grid: random holes, flipped/duplicate/zero-area triangles,
// non-manifold fins, isolated vertices and a disconnected second component.
Mesh makeRandomMesh(uint32_t seed);
// A slab of 40 x 40 x 6 voxels drilled through by a 4 x 4 lattice of one-voxel holes: a closed
// surface of genus 16, small tunnels like a scan's. A collapse that keeps topology cannot take a
// tunnel below a tube of triangles.
Mesh makeDrilledSlab();
// Positions and faces of an ASCII PLY (triangles; polygons fanned). nullopt when unreadable.
std::optional<Mesh> readAsciiPly(const std::filesystem::path& path);

} // namespace mirage::lodtest
