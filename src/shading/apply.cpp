// Applying a material file to an imported scene: assignment by name or glob (the last matching
// [[assign]] wins), the file's materials and textures appended, meshes re-pointed.
#include <fmt/format.h>

#include "mirage/shading/material_file.h"

namespace mirage::shading {

bool globMatch(std::string_view pattern, std::string_view text) {
  // Iterative matcher with one backtrack point (the last `*`): linear in practice, never exponential.
  size_t p = 0, t = 0, starP = std::string_view::npos, starT = 0;
  while (t < text.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[t])) {
      ++p, ++t;
    } else if (p < pattern.size() && pattern[p] == '*') {
      starP = p++;
      starT = t;
    } else if (starP != std::string_view::npos) {
      p = starP + 1;
      t = ++starT;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

namespace {

bool matches(const Assignment& a, const Scene& scene, const Mesh& mesh) {
  if (a.target == Assignment::Target::Mesh) return globMatch(a.pattern, mesh.name);
  return mesh.material < scene.materials.size() && globMatch(a.pattern, scene.materials[mesh.material].name);
}

// Colour maps are sRGB-encoded, data maps (normals, the detail albedo's neutral 0.5, masks) linear.
bool isSrgb(MaterialMap map) { return map == kMapBaseColor; }

} // namespace

Status applyMaterials(Scene& scene, const MaterialFile& file) {
  // Resolve against the scene as imported: which file material each mesh gets (-1: keeps its own).
  std::vector<int> chosen(scene.meshes.size(), -1);
  for (const Assignment& a : file.assignments) {
    bool any = false;
    for (size_t i = 0; i < scene.meshes.size(); ++i)
      if (matches(a, scene, scene.meshes[i])) chosen[i] = int(a.material), any = true;
    if (!any)
      return Error{fmt::format("{}:{}: assign: {} \"{}\" matches no {} of {}", file.name, a.line,
                               a.target == Assignment::Target::Mesh ? "mesh" : "material", a.pattern,
                               a.target == Assignment::Target::Mesh ? "mesh name" : "material name", scene.source)};
  }
  // Append each used file material once, with its textures (one scene texture per file texture and
  // colour space).
  std::vector<int> sceneMaterial(file.materials.size(), -1);
  std::vector<int> sceneTexture(file.textures.size() * 2, -1); // [texture * 2 + srgb]
  auto textureIndex = [&](int32_t fileTexture, MaterialMap map) -> int32_t {
    if (fileTexture < 0) return -1;
    int& slot = sceneTexture[size_t(fileTexture) * 2 + isSrgb(map)];
    if (slot < 0) {
      const FileTexture& ft = file.textures[size_t(fileTexture)];
      slot = int(scene.textures.size());
      scene.textures.push_back(
          Texture{ft.path.filename().string(), ft.image.width, ft.image.height, ft.image.pixels, isSrgb(map)});
    }
    return slot;
  };
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    if (chosen[i] < 0) continue;
    int& index = sceneMaterial[size_t(chosen[i])];
    if (index < 0) {
      const MaterialDef& d = file.materials[size_t(chosen[i])];
      Material m = d.material;
      m.baseColorTexture = textureIndex(d.textures[kMapBaseColor], kMapBaseColor);
      m.normalTexture = textureIndex(d.textures[kMapNormal], kMapNormal);
      m.detailAlbedoTexture = textureIndex(d.textures[kMapDetailAlbedo], kMapDetailAlbedo);
      m.detailNormalTexture = textureIndex(d.textures[kMapDetailNormal], kMapDetailNormal);
      m.detailMaskTexture = textureIndex(d.textures[kMapDetailMask], kMapDetailMask);
      index = int(scene.materials.size());
      scene.materials.push_back(std::move(m));
    }
    scene.meshes[i].material = uint32_t(index);
  }
  scene.lights.insert(scene.lights.end(), file.lights.begin(), file.lights.end());
  return Ok{};
}

} // namespace mirage::shading
