#include "mirage/io/mesh_utils.h"

#include <cmath>

#include <fmt/format.h>
#include <meshoptimizer.h>

namespace mirage::io {

void computeNormals(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  mesh.normals.assign(n, glm::vec3(0.0f));
  const auto& p = mesh.positions;
  const auto& idx = mesh.indices;
  for (size_t t = 0; t + 2 < idx.size(); t += 3) {
    uint32_t a = idx[t], b = idx[t + 1], c = idx[t + 2];
    // Unnormalised: its length is twice the area, which is the weight we want.
    glm::vec3 fn = glm::cross(p[b] - p[a], p[c] - p[a]);
    mesh.normals[a] += fn;
    mesh.normals[b] += fn;
    mesh.normals[c] += fn;
  }
  for (glm::vec3& v : mesh.normals) {
    float len2 = glm::dot(v, v);
    // A vertex with no area around it (isolated or only degenerate triangles) still needs a unit normal.
    v = (len2 > 0.0f && std::isfinite(len2)) ? v / std::sqrt(len2) : glm::vec3(0.0f, 0.0f, 1.0f);
  }
}

void computeBounds(Mesh& mesh) {
  Bounds b;
  for (const glm::vec3& v : mesh.positions) b.add(v);
  mesh.bounds = b;
}

void weldMesh(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  if (n == 0 || mesh.indices.empty()) return;
  std::vector<meshopt_Stream> streams;
  streams.push_back({mesh.positions.data(), sizeof(glm::vec3), sizeof(glm::vec3)});
  if (mesh.normals.size() == n) streams.push_back({mesh.normals.data(), sizeof(glm::vec3), sizeof(glm::vec3)});
  if (mesh.tangents.size() == n) streams.push_back({mesh.tangents.data(), sizeof(glm::vec4), sizeof(glm::vec4)});
  if (mesh.uv0.size() == n) streams.push_back({mesh.uv0.data(), sizeof(glm::vec2), sizeof(glm::vec2)});
  if (mesh.colors.size() == n) streams.push_back({mesh.colors.data(), sizeof(glm::vec4), sizeof(glm::vec4)});

  std::vector<unsigned int> remap(n);
  size_t unique = meshopt_generateVertexRemapMulti(remap.data(), mesh.indices.data(), mesh.indices.size(), n,
                                                   streams.data(), streams.size());
  if (unique == n) return; // nothing to merge and no unused vertices: skip the copies
  meshopt_remapIndexBuffer(mesh.indices.data(), mesh.indices.data(), mesh.indices.size(), remap.data());
  auto remapStream = [&](auto& v) {
    if (v.size() != n) return;
    std::remove_reference_t<decltype(v)> out(unique);
    meshopt_remapVertexBuffer(out.data(), v.data(), n, sizeof(v[0]), remap.data());
    v.swap(out);
  };
  remapStream(mesh.positions);
  remapStream(mesh.normals);
  remapStream(mesh.tangents);
  remapStream(mesh.uv0);
  remapStream(mesh.colors);
}

void computeTangents(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  if (mesh.uv0.size() != n || mesh.normals.size() != n) {
    mesh.tangents.clear();
    return;
  }
  std::vector<glm::vec3> tan(n, glm::vec3(0.0f)), bit(n, glm::vec3(0.0f));
  const auto& p = mesh.positions;
  const auto& uv = mesh.uv0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
    glm::vec3 e1 = p[b] - p[a], e2 = p[c] - p[a];
    glm::vec2 d1 = uv[b] - uv[a], d2 = uv[c] - uv[a];
    float det = d1.x * d2.y - d2.x * d1.y;
    if (std::fabs(det) < 1e-20f) continue; // no UV area: contributes no direction
    float r = 1.0f / det;
    glm::vec3 s = (e1 * d2.y - e2 * d1.y) * r;
    glm::vec3 tt = (e2 * d1.x - e1 * d2.x) * r;
    for (uint32_t v : {a, b, c}) {
      tan[v] += s;
      bit[v] += tt;
    }
  }
  mesh.tangents.resize(n);
  for (size_t i = 0; i < n; ++i) {
    glm::vec3 nn = mesh.normals[i];
    glm::vec3 t = tan[i] - nn * glm::dot(nn, tan[i]);
    float len = glm::length(t);
    if (!(len > 1e-12f)) {
      // Any vector perpendicular to the normal keeps the basis valid where UVs are degenerate.
      t = std::fabs(nn.x) < 0.9f ? glm::cross(nn, glm::vec3(1, 0, 0)) : glm::cross(nn, glm::vec3(0, 1, 0));
      len = glm::length(t);
    }
    t /= len;
    float w = glm::dot(glm::cross(nn, t), bit[i]) < 0.0f ? -1.0f : 1.0f;
    mesh.tangents[i] = glm::vec4(t, w);
  }
}

Status validateMesh(const Mesh& mesh, const std::string& file) {
  auto fail = [&](const std::string& problem) -> Status {
    return makeError(file, fmt::format("mesh '{}': {}", mesh.name, problem));
  };
  const size_t n = mesh.positions.size();
  if (mesh.indices.empty() || n == 0) return fail("empty mesh (no triangles)");
  if (mesh.indices.size() % 3 != 0)
    return fail(fmt::format("index count {} is not a multiple of 3", mesh.indices.size()));
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= n)
      return fail(fmt::format("index {} at position {} is out of range ({} vertices)", mesh.indices[i], i, n));
  for (size_t i = 0; i < n; ++i) {
    const glm::vec3& v = mesh.positions[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      return fail(fmt::format("vertex {} has a non-finite position (NaN or Inf)", i));
  }
  auto sized = [n](const auto& v) { return v.empty() || v.size() == n; };
  if (!sized(mesh.normals) || !sized(mesh.tangents) || !sized(mesh.uv0) || !sized(mesh.colors))
    return fail("attribute array size differs from the vertex count");
  return Ok{};
}

} // namespace mirage::io
