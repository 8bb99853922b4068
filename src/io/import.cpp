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
  if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(displayName(path), problem);
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(displayName(path), "cannot open file");
  std::error_code ec;
  auto size = std::filesystem::file_size(path, ec);
  if (ec) return makeError(displayName(path), "cannot determine file size");
  std::vector<char> data(size);
  if (size > 0 && !in.read(data.data(), static_cast<std::streamsize>(size)))
    return makeError(displayName(path), "read error");
  return data;
}

std::string decodeImageProblem(const unsigned char* bytes, size_t size, Texture& out) {
  if (size == 0) return "empty image";
  if (size > size_t(INT32_MAX)) return "image file over 2 GiB";
  int w = 0, h = 0, comp = 0;
  if (!stbi_info_from_memory(bytes, int(size), &w, &h, &comp))
    return fmt::format("cannot decode image ({})", stbi_failure_reason());
  if (w <= 0 || h <= 0 || uint32_t(w) > kMaxTextureSide || uint32_t(h) > kMaxTextureSide)
    return fmt::format("image is {}x{}, over the {}-pixel limit per side", w, h, kMaxTextureSide);
  // Request 4 channels so every texture lands as RGBA8 whatever the file stores.
  stbi_uc* pixels = stbi_load_from_memory(bytes, int(size), &w, &h, &comp, 4);
  if (!pixels) return fmt::format("cannot decode image ({})", stbi_failure_reason());
  out.width = static_cast<uint32_t>(w);
  out.height = static_cast<uint32_t>(h);
  out.rgba8.assign(pixels, pixels + size_t(w) * size_t(h) * 4);
  stbi_image_free(pixels);
  return {};
}

Status loadImageFile(const std::filesystem::path& path, const std::string& file, const std::string& what,
                     Texture& out) {
  if (std::string problem = inputFileProblem(path); !problem.empty())
    return makeError(file, fmt::format("{}: {}", what, problem));
  auto bytes = readFile(path);
  if (!bytes) return makeError(file, fmt::format("{}: cannot read the file", what));
  out.name = path.filename().string();
  std::string problem = decodeImageProblem(reinterpret_cast<const unsigned char*>(bytes->data()), bytes->size(), out);
  if (!problem.empty()) return makeError(file, fmt::format("{}: {}", what, problem));
  return Ok{};
}

namespace {

template <class V> bool finite(const V& v) {
  for (int k = 0; k < V::length(); ++k)
    if (!std::isfinite(v[k])) return false;
  return true;
}
bool finite(float f) { return std::isfinite(f); }
bool finite(const glm::mat4& m) { return finite(m[0]) && finite(m[1]) && finite(m[2]) && finite(m[3]); }

// Materials and placements: everything the asset writer and the renderers require to be finite, checked where the
// input is known, so info, render and build reject the same file with the same words.
Status validateScene(const Scene& scene, const std::string& file) {
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    if (!finite(m.baseColorFactor) || !finite(m.emissiveFactor) || !finite(m.metallicFactor) ||
        !finite(m.roughnessFactor) || !finite(m.normalScale) || !finite(m.occlusionStrength) || !finite(m.alphaCutoff))
      return makeError(file, fmt::format("material {} {}: a factor is NaN or infinite", i, quoteInput(m.name)));
  }
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    if (inst.mesh >= scene.meshes.size()) return makeError(file, fmt::format("instance {}: bad mesh", i));
    const Mesh& mesh = scene.meshes[inst.mesh];
    if (!finite(inst.transform))
      return makeError(file, fmt::format("mesh {} placed by a NaN or infinite transform", quoteInput(mesh.name)));
    // A finite but huge transform can still carry the mesh past float range.
    Bounds world = transformBounds(mesh.bounds, inst.transform);
    if (!finite(world.min) || !finite(world.max))
      return makeError(file,
                       fmt::format("mesh {} placed beyond float range (transform too large)", quoteInput(mesh.name)));
  }
  return Ok{};
}

} // namespace

Status finalizeScene(Scene& scene, const std::string& file, const ImportOptions& options) {
  size_t triangles = 0;
  for (const Mesh& m : scene.meshes) triangles += m.triangleCount();
  if (scene.meshes.empty()) return makeError(file, "no triangles");
  if (triangles == 0 && !options.allowPointClouds) {
    size_t points = 0;
    for (const Mesh& m : scene.meshes) points += m.positions.size();
    // Say what the file does hold: a scan's PLY without faces is a point cloud, readable where points are accepted.
    if (points > 0) return makeError(file, fmt::format("no triangles: a point cloud of {} points", points));
    return makeError(file, "no triangles");
  }
  if (triangles == 0) { // a point cloud: unit normals where the file has them, nothing to weld or compute
    for (Mesh& m : scene.meshes) {
      if (m.positions.empty()) return makeError(file, "no points");
      if (!m.indices.empty()) return makeError(file, "a point cloud with a face list");
      if (!m.normals.empty() && m.normals.size() != m.positions.size()) return makeError(file, "normal count mismatch");
      if (!m.colors.empty() && m.colors.size() != m.positions.size()) return makeError(file, "colour count mismatch");
      if (Status s = validateFinite(m, file); !s) return s;
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
    // approximately unit); renderers and the surfel sampler assume unit length. Zero or overflowing (but finite)
    // normals carry no direction: +Z, which computeNormals would also give a vertex without area.
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
    if (m.material >= scene.materials.size())
      return makeError(file, fmt::format("mesh {}: bad material", quoteInput(m.name)));
  if (scene.instances.empty())
    for (uint32_t i = 0; i < scene.meshes.size(); ++i) scene.instances.push_back(Instance{i, glm::mat4(1.0f)});
  if (Status s = validateScene(scene, file); !s) return s;
  scene.source = file;
  return Ok{};
}

} // namespace detail

Result<Scene> importScene(const std::filesystem::path& path, const ImportOptions& options) {
  // The file before its name: a directory called "x.glb" or "scans" gets the same words as any other.
  if (std::string problem = inputFileProblem(path); !problem.empty())
    return makeError(detail::displayName(path), problem);
  if (std::error_code ec; std::filesystem::file_size(path, ec) == 0 && !ec)
    return makeError(detail::displayName(path), "empty file (0 bytes)");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".gltf" || ext == ".glb") return importGltf(path, options);
  if (ext == ".obj") return importObj(path, options);
  if (ext == ".ply") return importPly(path, options);
  return makeError(detail::displayName(path),
                   fmt::format("unknown scene file extension {} (expected .gltf .glb .obj .ply)", quoteInput(ext)));
}

} // namespace mirage::io
