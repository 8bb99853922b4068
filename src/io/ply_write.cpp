#include "mirage/io/ply_write.h"

#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "mirage/io/image_io.h"

namespace mirage::io {

Status writePly(const Scene& scene, const std::filesystem::path& path, const PlyWriteOptions& options) {
  size_t vertexCount = 0, faceCount = 0;
  for (const Instance& inst : scene.instances) {
    vertexCount += scene.meshes[inst.mesh].positions.size();
    faceCount += scene.meshes[inst.mesh].triangleCount();
  }
  if (vertexCount > UINT32_MAX) return makeError(path.string(), "too many vertices for 32-bit PLY indices");
  std::string header = fmt::format(
      "ply\nformat binary_little_endian 1.0\ncomment written by mirage\nelement vertex {}\n"
      "property float x\nproperty float y\nproperty float z\n{}element face {}\n"
      "property list uchar int vertex_indices\nend_header\n",
      vertexCount, options.normals ? "property float nx\nproperty float ny\nproperty float nz\n" : "", faceCount);
  size_t vertexBytes = options.normals ? 24 : 12;
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
