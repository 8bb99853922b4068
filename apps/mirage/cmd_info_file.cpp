// mirage info FILE: what a scene file holds.
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "lod_common.h"
#include "mirage/io/import.h"
#include "mirage/lod/lod_asset.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

// A baked .mrg: levels, clusters and triangles per level, fill, root size, bytes per input triangle.
void infoAsset(const std::string& path, bool json) {
  auto a = lod::loadLodAsset(path);
  if (!a) return fail(a.error());
  BuildSummary s = summarize(*a, path);
  if (json) {
    nlohmann::json j = summaryJson(s);
    j["file"] = path;
    j["instances"] = a->scene.instances.size();
    j["materials"] = a->scene.materials.size();
    j["textures"] = a->scene.textures.size();
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}: cluster-LOD asset, {} meshes, {} instances, {} materials, {} textures, {} input triangles\n", path,
             s.meshes, a->scene.instances.size(), a->scene.materials.size(), a->scene.textures.size(),
             s.inputTriangles);
  printSummary(s);
}

} // namespace

void infoFile(const std::string& path, bool json) {
  if (path.ends_with(".mrg")) return infoAsset(path, json);
  auto scene = loadSceneArgument(path);
  if (!scene) return fail(scene.error());
  const Scene& s = *scene;
  Bounds b = s.worldBounds();
  size_t vertices = 0;
  for (const Mesh& m : s.meshes) vertices += m.vertexCount();
  size_t blend = 0, mask = 0;
  for (const Material& m : s.materials)
    blend += m.alphaMode == AlphaMode::Blend, mask += m.alphaMode == AlphaMode::Mask;
  if (json) {
    nlohmann::json j = {{"file", path},
                        {"meshes", s.meshes.size()},
                        {"instances", s.instances.size()},
                        {"triangles", s.meshTriangleCount()},
                        {"instanced_triangles", s.instancedTriangleCount()},
                        {"vertices", vertices},
                        {"materials", s.materials.size()},
                        {"materials_mask", mask},
                        {"materials_blend", blend},
                        {"textures", s.textures.size()},
                        {"bounds_min", {b.min.x, b.min.y, b.min.z}},
                        {"bounds_max", {b.max.x, b.max.y, b.max.z}}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  meshes {}  instances {}  triangles {} ({} instanced)  vertices {}\n", s.meshes.size(),
             s.instances.size(), s.meshTriangleCount(), s.instancedTriangleCount(), vertices);
  fmt::print("  materials {} ({} mask, {} blend)  textures {}\n", s.materials.size(), mask, blend, s.textures.size());
  fmt::print("  bounds ({:.4g}, {:.4g}, {:.4g}) .. ({:.4g}, {:.4g}, {:.4g})\n", b.min.x, b.min.y, b.min.z, b.max.x,
             b.max.y, b.max.z);
}

} // namespace mirage::cli
