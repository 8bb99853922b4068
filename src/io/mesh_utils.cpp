#include "mirage/io/mesh_utils.h"

#include <cmath>
#include <cstring>

#include <fmt/format.h>

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

namespace {

// The bytes of vertex i across all present attribute streams.
struct VertexBytes {
  std::vector<std::pair<const uint8_t*, size_t>> streams; // base, stride (= element size)
  template <class V> void add(const std::vector<V>& v, size_t n) {
    if (v.size() == n) streams.push_back({reinterpret_cast<const uint8_t*>(v.data()), sizeof(V)});
  }
  uint32_t hash(size_t i) const {
    uint32_t h = 2166136261u; // FNV-1a over 32-bit words, then a final avalanche
    for (const auto& [base, size] : streams) {
      const uint8_t* p = base + i * size;
      for (size_t k = 0; k < size; k += 4) {
        uint32_t w;
        std::memcpy(&w, p + k, 4);
        h = (h ^ w) * 16777619u;
      }
    }
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    return h;
  }
  bool equal(size_t a, size_t b) const {
    for (const auto& [base, size] : streams)
      if (std::memcmp(base + a * size, base + b * size, size) != 0) return false;
    return true;
  }
};

// Stable LSD radix sort of (hash << 32 | index) keys by their hash (upper 32 bits), 11-bit digits.
void radixSortByHash(std::vector<uint64_t>& keys) {
  std::vector<uint64_t> tmp(keys.size());
  for (int shift = 32; shift < 64; shift += 11) {
    size_t count[2048] = {};
    for (uint64_t k : keys) ++count[(k >> shift) & 2047];
    size_t sum = 0;
    for (size_t& c : count) {
      size_t t = c;
      c = sum;
      sum += t;
    }
    for (uint64_t k : keys) tmp[count[(k >> shift) & 2047]++] = k;
    keys.swap(tmp);
  }
}

} // namespace

// Duplicates are found by sorting vertex hashes (sequential memory traffic) rather than with a hash table: on
// scan-sized meshes (millions of vertices) this is several times faster than meshopt_generateVertexRemapMulti,
// whose random probes dominated binary PLY import time. Result is the same set of unique vertices; survivors keep
// their original relative order, and vertices no triangle uses are dropped.
void weldMesh(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  if (n == 0 || mesh.indices.empty() || n >= (size_t(1) << 32)) return;
  VertexBytes vb;
  vb.add(mesh.positions, n);
  vb.add(mesh.normals, n);
  vb.add(mesh.tangents, n);
  vb.add(mesh.uv0, n);
  vb.add(mesh.colors, n);

  std::vector<uint64_t> keys(n);
  for (size_t i = 0; i < n; ++i) keys[i] = (uint64_t(vb.hash(i)) << 32) | i;
  radixSortByHash(keys);

  // canon[i]: the lowest-index vertex equal to i (runs of equal hash are tiny: compare within them).
  std::vector<uint32_t> canon(n);
  for (size_t i = 0; i < n; ++i) canon[i] = uint32_t(i);
  bool merged = false;
  for (size_t a = 0; a < n;) {
    size_t b = a + 1;
    while (b < n && (keys[b] >> 32) == (keys[a] >> 32)) ++b;
    for (size_t j = a + 1; j < b; ++j) {
      uint32_t vj = uint32_t(keys[j]);
      for (size_t k = a; k < j; ++k) {
        uint32_t vk = uint32_t(keys[k]);
        if (canon[vk] == vk && vb.equal(vk, vj)) { // stable sort: vk < vj
          canon[vj] = vk;
          merged = true;
          break;
        }
      }
    }
    a = b;
  }
  keys = {};

  std::vector<uint8_t> used(n, 0);
  for (uint32_t idx : mesh.indices) used[canon[idx]] = 1;
  size_t unique = 0;
  for (uint8_t u : used) unique += u;
  if (!merged && unique == n) return; // nothing to merge, nothing unused: leave the mesh untouched

  std::vector<uint32_t> newId(n, ~0u);
  for (size_t i = 0, next = 0; i < n; ++i)
    if (used[i]) newId[i] = uint32_t(next++);
  for (uint32_t& idx : mesh.indices) idx = newId[canon[idx]];
  auto compact = [&](auto& v) {
    if (v.size() != n) return;
    for (size_t i = 0; i < n; ++i)
      if (used[i]) v[newId[i]] = v[i]; // newId[i] <= i: in-place forward compaction is safe
    v.resize(unique);
    v.shrink_to_fit();
  };
  compact(mesh.positions);
  compact(mesh.normals);
  compact(mesh.tangents);
  compact(mesh.uv0);
  compact(mesh.colors);
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
