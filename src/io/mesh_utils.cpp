#include "mirage/io/mesh_utils.h"

#include <cmath>
#include <cstring>
#include <optional>

#include <fmt/format.h>

#include "mirage/core/input_text.h"

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

} // namespace

// Duplicates are found in two cache-friendly steps instead of one big hash table: vertices are scattered by the top
// bits of their hash into buckets (one sequential pass), then each bucket, small enough for L2, is deduplicated with
// a local open-addressing table. On scan-sized meshes this is several times faster than
// meshopt_generateVertexRemapMulti, whose random probes dominated binary PLY import. The result is the same set of
// unique vertices (bit-equal in all attributes); survivors keep their original order; unused vertices are dropped.
void weldMesh(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  if (n == 0 || mesh.indices.empty() || n >= (size_t(1) << 32)) return;
  VertexBytes vb;
  vb.add(mesh.positions, n);
  vb.add(mesh.normals, n);
  vb.add(mesh.tangents, n);
  vb.add(mesh.uv0, n);
  vb.add(mesh.colors, n);

  std::vector<uint32_t> hashes(n);
  for (size_t i = 0; i < n; ++i) hashes[i] = vb.hash(i);
  // Enough buckets for ~4K vertices each; their tables then stay cache resident.
  int bucketBits = 0;
  while (bucketBits < 16 && (n >> bucketBits) > 4096) ++bucketBits;
  const int shift = 32 - bucketBits;
  auto bucketOf = [&](uint32_t h) { return bucketBits ? h >> shift : 0u; };
  std::vector<size_t> start((size_t(1) << bucketBits) + 1, 0);
  for (uint32_t h : hashes) ++start[bucketOf(h) + 1];
  for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
  std::vector<uint32_t> order(n); // vertex ids grouped by bucket, ascending within each (stable scatter)
  {
    std::vector<size_t> fill(start.begin(), start.end() - 1);
    for (size_t i = 0; i < n; ++i) order[fill[bucketOf(hashes[i])]++] = uint32_t(i);
  }

  // canon[i]: the lowest-index vertex equal to i.
  std::vector<uint32_t> canon(n);
  for (size_t i = 0; i < n; ++i) canon[i] = uint32_t(i);
  bool merged = false;
  // Slots hold (hash, id) so probing never touches the (randomly placed) vertex data unless the hashes match.
  std::vector<std::pair<uint32_t, uint32_t>> table;
  for (size_t b = 0; b + 1 < start.size(); ++b) {
    const size_t count = start[b + 1] - start[b];
    if (count < 2) continue;
    size_t cap = 16;
    while (cap < count * 2) cap <<= 1;
    table.assign(cap, {0u, ~0u});
    for (size_t k = start[b]; k < start[b + 1]; ++k) {
      uint32_t v = order[k], h = hashes[v];
      for (size_t slot = (h * 0x9E3779B1u) & (cap - 1);; slot = (slot + 1) & (cap - 1)) {
        auto [th, rep] = table[slot];
        if (rep == ~0u) {
          table[slot] = {h, v};
          break;
        }
        if (th == h && vb.equal(rep, v)) { // rep < v: ids ascend within a bucket
          canon[v] = rep;
          merged = true;
          break;
        }
      }
    }
  }
  hashes = {};
  order = {};

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

namespace {

template <class V> std::optional<size_t> firstNonFinite(const std::vector<V>& values) {
  for (size_t i = 0; i < values.size(); ++i)
    for (int k = 0; k < V::length(); ++k)
      if (!std::isfinite(values[i][k])) return i;
  return std::nullopt;
}

} // namespace

Status validateFinite(const Mesh& mesh, const std::string& file) {
  auto fail = [&](const char* what, size_t i) -> Status {
    return makeError(
        file, fmt::format("mesh {}: vertex {} has a non-finite {} (NaN or Inf)", quoteInput(mesh.name), i, what));
  };
  if (auto i = firstNonFinite(mesh.positions)) return fail("position", *i);
  if (auto i = firstNonFinite(mesh.normals)) return fail("normal", *i);
  if (auto i = firstNonFinite(mesh.tangents)) return fail("tangent", *i);
  if (auto i = firstNonFinite(mesh.uv0)) return fail("texture coordinate", *i);
  if (auto i = firstNonFinite(mesh.colors)) return fail("colour", *i);
  return Ok{};
}

Status validateMesh(const Mesh& mesh, const std::string& file) {
  auto fail = [&](const std::string& problem) -> Status {
    return makeError(file, fmt::format("mesh {}: {}", quoteInput(mesh.name), problem));
  };
  const size_t n = mesh.positions.size();
  if (mesh.indices.empty() || n == 0) return fail("empty mesh (no triangles)");
  if (mesh.indices.size() % 3 != 0)
    return fail(fmt::format("index count {} is not a multiple of 3", mesh.indices.size()));
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= n)
      return fail(fmt::format("index {} at position {} is out of range ({} vertices)", mesh.indices[i], i, n));
  auto sized = [n](const auto& v) { return v.empty() || v.size() == n; };
  if (!sized(mesh.normals) || !sized(mesh.tangents) || !sized(mesh.uv0) || !sized(mesh.colors))
    return fail("attribute array size differs from the vertex count");
  return validateFinite(mesh, file);
}

} // namespace mirage::io
