#include "mirage/io/import.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <stb/stb_image.h>

#include "import_internal.h"
#include "mirage/io/mesh_utils.h"

namespace mirage::io {

namespace detail {

Result<std::vector<char>> readFile(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return makeError(displayName(path), "file not found");
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(displayName(path), "cannot open file");
  auto size = std::filesystem::file_size(path, ec);
  if (ec) return makeError(displayName(path), "cannot determine file size");
  std::vector<char> data(size);
  if (size > 0 && !in.read(data.data(), static_cast<std::streamsize>(size)))
    return makeError(displayName(path), "read error");
  return data;
}

bool loadImageFile(const std::filesystem::path& path, Texture& out) {
  int w = 0, h = 0, comp = 0;
  // Request 4 channels so every texture lands as RGBA8 whatever the file stores.
  stbi_uc* pixels = stbi_load(path.string().c_str(), &w, &h, &comp, 4);
  if (!pixels) return false;
  out.name = path.filename().string();
  out.width = static_cast<uint32_t>(w);
  out.height = static_cast<uint32_t>(h);
  out.rgba8.assign(pixels, pixels + size_t(w) * size_t(h) * 4);
  stbi_image_free(pixels);
  return true;
}

Status finalizeScene(Scene& scene, const std::string& file, const ImportOptions& options) {
  size_t triangles = 0;
  for (const Mesh& m : scene.meshes) triangles += m.triangleCount();
  if (scene.meshes.empty()) return makeError(file, "no triangles");
  if (triangles == 0 && !options.allowPointClouds) return makeError(file, "no triangles");
  if (triangles == 0) { // a point cloud: unit normals where the file has them, nothing to weld or compute
    for (Mesh& m : scene.meshes) {
      if (m.positions.empty()) return makeError(file, "no points");
      if (!m.indices.empty()) return makeError(file, "a point cloud with a face list");
      if (!m.normals.empty() && m.normals.size() != m.positions.size()) return makeError(file, "normal count mismatch");
      if (!m.colors.empty() && m.colors.size() != m.positions.size()) return makeError(file, "colour count mismatch");
    }
  }
  for (Mesh& m : scene.meshes) {
    if (triangles == 0) {
      for (glm::vec3& n : m.normals) {
        float len2 = glm::dot(n, n);
        n = (len2 > 0.0f && std::isfinite(len2)) ? n / std::sqrt(len2) : glm::vec3(0.0f, 0.0f, 1.0f);
      }
      computeBounds(m);
      continue;
    }
    if (Status s = validateMesh(m, file); !s) return s;
    // File normals are not always unit (VCG's PLY writer stores area-weighted sums, quantized glTF normals are
    // approximately unit); renderers and the surfel sampler assume unit length.
    for (glm::vec3& n : m.normals) {
      float len2 = glm::dot(n, n);
      n = (len2 > 0.0f && std::isfinite(len2)) ? n / std::sqrt(len2) : glm::vec3(0.0f, 0.0f, 1.0f);
    }
    if (options.weld) weldMesh(m);
    if (m.normals.size() != m.positions.size()) computeNormals(m);
    computeBounds(m);
  }
  if (scene.materials.empty()) {
    Material def;
    def.name = "default";
    def.metallicFactor = 0.0f; // a plain dielectric reads better than the glTF default (metal) for untextured scans
    scene.materials.push_back(def);
  }
  for (Mesh& m : scene.meshes)
    if (m.material >= scene.materials.size()) return makeError(file, fmt::format("mesh '{}': bad material", m.name));
  if (scene.instances.empty())
    for (uint32_t i = 0; i < scene.meshes.size(); ++i) scene.instances.push_back(Instance{i, glm::mat4(1.0f)});
  scene.source = file;
  return Ok{};
}

} // namespace detail

Result<Scene> importScene(const std::filesystem::path& path, const ImportOptions& options) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".gltf" || ext == ".glb") return importGltf(path, options);
  if (ext == ".obj") return importObj(path, options);
  if (ext == ".ply") return importPly(path, options);
  return makeError(detail::displayName(path),
                   fmt::format("unknown scene file extension '{}' (expected .gltf .glb .obj .ply)", ext));
}

} // namespace mirage::io
