#include "mirage/visibility/pvs_cull.h"

#include <algorithm>

#include "mirage/visibility/ray_backend.h"

namespace mirage::vis {

int findCell(const std::vector<ViewCell>& cells, glm::vec3 p) {
  for (size_t i = 0; i < cells.size(); ++i)
    if (cells[i].contains(p)) return int(i);
  return -1;
}

Result<Scene> restrictToPvs(const Scene& scene, std::span<const uint32_t> ids) {
  std::vector<uint64_t> offsets = triangleOffsets(scene);
  uint64_t total = scene.instancedTriangleCount();
  if (!ids.empty() && ids.back() >= total)
    return Error{scene.source + ": PVS triangle " + std::to_string(ids.back()) + " is outside the scene's " +
                 std::to_string(total) + " triangles (a PVS of another scene?)"};
  Scene out;
  out.source = scene.source + " (PVS)";
  out.materials = scene.materials;
  out.textures = scene.textures;
  size_t next = 0; // ids are sorted and instances are contiguous ranges: one merge-like pass
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    const Mesh& mesh = scene.meshes[inst.mesh];
    uint64_t begin = offsets[i], end = begin + mesh.triangleCount();
    while (next < ids.size() && ids[next] < begin) ++next;
    size_t first = next;
    while (next < ids.size() && ids[next] < end) ++next;
    if (next == first) continue;
    // Vertices stay shared with the source mesh's arrays (copied whole): only indices shrink,
    // which is what the rasterizer's cost follows.
    Mesh m = mesh;
    m.name = mesh.name + " (PVS)";
    m.indices.clear();
    m.indices.reserve((next - first) * 3);
    for (size_t k = first; k < next; ++k) {
      size_t t = size_t(ids[k] - begin);
      m.indices.insert(m.indices.end(), mesh.indices.begin() + t * 3, mesh.indices.begin() + t * 3 + 3);
    }
    out.meshes.push_back(std::move(m));
    out.instances.push_back({uint32_t(out.meshes.size() - 1), inst.transform});
  }
  return out;
}

} // namespace mirage::vis
