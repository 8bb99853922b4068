#pragma once
// Binary little-endian PLY export: what a scanner would hand Mirage (large meshes for import and
// LOD benchmarks). Instances are baked: every instance's triangles are written in world space.
#include <filesystem>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

struct PlyWriteOptions {
  bool normals = false; // write nx, ny, nz per vertex (scans such as Lucy have positions only)
  bool colors = false;  // write uchar red, green, blue per vertex (sRGB-encoded; white where a mesh has none)
};

// Written atomically (temp file + rename). A scene without triangles is written without a face
// element: a point cloud, as a scanner's PLY.
Status writePly(const Scene& scene, const std::filesystem::path& path, const PlyWriteOptions& options = {});

} // namespace mirage::io
