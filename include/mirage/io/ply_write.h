#pragma once
// Binary little-endian PLY export: what a scanner would hand Mirage (large meshes for import and
// LOD benchmarks). Instances are baked: every instance's triangles are written in world space.
#include <filesystem>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

struct PlyWriteOptions {
  bool normals = false; // write nx, ny, nz per vertex (scans such as Lucy have positions only)
};

// Written atomically (temp file + rename).
Status writePly(const Scene& scene, const std::filesystem::path& path, const PlyWriteOptions& options = {});

} // namespace mirage::io
