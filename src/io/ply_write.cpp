#include "mirage/io/ply_write.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "mirage/io/image_io.h"

namespace mirage::io {

namespace {

uint8_t srgbByte(float linear) {
  float c = std::clamp(linear, 0.0f, 1.0f);
  float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return uint8_t(s * 255.0f + 0.5f);
}

} // namespace

Status writePly(const Scene& scene, const std::filesystem::path& path, const PlyWriteOptions& options) {
  size_t vertexCount = 0, faceCount = 0;
  for (const Instance& inst : scene.instances) {
    vertexCount += scene.meshes[inst.mesh].positions.size();
    faceCount += scene.meshes[inst.mesh].triangleCount();
  }
  if (vertexCount > UINT32_MAX) return makeError(path.string(), "too many vertices for 32-bit PLY indices");
  std::string header =
      fmt::format("ply\nformat binary_little_endian 1.0\ncomment written by mirage\nelement vertex {}\n"
                  "property float x\nproperty float y\nproperty float z\n{}{}{}end_header\n",
                  vertexCount, options.normals ? "property float nx\nproperty float ny\nproperty float nz\n" : "",
                  options.colors ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "",
                  faceCount ? fmt::format("element face {}\nproperty list uchar int vertex_indices\n", faceCount) : "");
  size_t vertexBytes = 12 + (options.normals ? 12 : 0) + (options.colors ? 3 : 0);
  std::vector<uint8_t> vertices(vertexCount * vertexBytes);
  std::vector<uint8_t> faces(faceCount * 13);
  uint8_t* v = vertices.data();
  uint8_t* f = faces.data();
  uint32_t base = 0;
  for (const Instance& inst : scene.instances) {
    const Mesh& m = scene.meshes[inst.mesh];
    glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(inst.transform)));
    for (size_t i = 0; i < m.positions.size(); ++i) {
      glm::vec3 p = glm::vec3(inst.transform * glm::vec4(m.positions[i], 1.0f));
      std::memcpy(v, &p, 12);
      if (options.normals) {
        glm::vec3 n = i < m.normals.size() ? glm::normalize(normalMatrix * m.normals[i]) : glm::vec3(0.0f);
        std::memcpy(v + 12, &n, 12);
      }
      if (options.colors) {
        glm::vec4 c = i < m.colors.size() ? m.colors[i] : glm::vec4(1.0f);
        uint8_t* rgb = v + (options.normals ? 24 : 12);
        for (int k = 0; k < 3; ++k) rgb[k] = srgbByte(c[k]);
      }
      v += vertexBytes;
    }
    for (size_t t = 0; t < m.indices.size(); t += 3) {
      *f++ = 3;
      for (int k = 0; k < 3; ++k) {
        int32_t index = int32_t(base + m.indices[t + k]);
        std::memcpy(f, &index, 4);
        f += 4;
      }
    }
    base += uint32_t(m.positions.size());
  }
  std::span<const uint8_t> parts[] = {
      {reinterpret_cast<const uint8_t*>(header.data()), header.size()}, vertices, faces};
  return writeFileAtomic(path, parts);
}

} // namespace mirage::io
