#include "mesh_prep.h"

#include <algorithm>
#include <array>
#include <cstring>

namespace mirage::lod::detail {

namespace {

uint32_t floatBits(float f) {
  f += 0.0f; // -0 and +0 weld together
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

size_t tableSize(size_t n) {
  size_t size = 16;
  while (size < n * 2) size *= 2; // load factor <= 0.5 keeps linear probing short
  return size;
}

} // namespace

Welded weldPositions(const std::vector<glm::vec3>& positions) {
  Welded w;
  w.vertexPosition.resize(positions.size());
  size_t size = tableSize(positions.size());
  std::vector<uint32_t> table(size, ~0u); // holds welded position ids
  for (size_t i = 0; i < positions.size(); ++i) {
    glm::vec3 p = positions[i];
    uint32_t x = floatBits(p.x), y = floatBits(p.y), z = floatBits(p.z);
    size_t h = mix64((uint64_t(x) << 32 | y) ^ mix64(z)) & (size - 1);
    for (;;) {
      uint32_t id = table[h];
      if (id == ~0u) {
        id = uint32_t(w.positions.size());
        w.positions.push_back(glm::vec3(p.x + 0.0f, p.y + 0.0f, p.z + 0.0f));
        table[h] = id;
        w.vertexPosition[i] = id;
        break;
      }
      glm::vec3 q = w.positions[id];
      if (floatBits(q.x) == x && floatBits(q.y) == y && floatBits(q.z) == z) {
        w.vertexPosition[i] = id;
        break;
      }
      h = (h + 1) & (size - 1);
    }
  }
  return w;
}

std::vector<uint32_t> cleanTriangles(const std::vector<uint32_t>& indices,
                                     const std::vector<uint32_t>& vertexPosition) {
  size_t triCount = indices.size() / 3;
  std::vector<uint32_t> out;
  out.reserve(triCount * 3);
  size_t size = tableSize(triCount);
  std::vector<uint32_t> table(size, ~0u); // holds output triangle ids
  auto sortedKey = [&](const uint32_t* t) {
    std::array<uint32_t, 3> k{vertexPosition[t[0]], vertexPosition[t[1]], vertexPosition[t[2]]};
    std::sort(k.begin(), k.end());
    return k;
  };
  for (size_t t = 0; t < triCount; ++t) {
    const uint32_t* tri = &indices[t * 3];
    std::array<uint32_t, 3> k = sortedKey(tri);
    if (k[0] == k[1] || k[1] == k[2]) continue; // zero area by construction
    size_t h = mix64((uint64_t(k[0]) << 32 | k[1]) ^ mix64(k[2])) & (size - 1);
    bool duplicate = false;
    for (;;) {
      uint32_t id = table[h];
      if (id == ~0u) {
        table[h] = uint32_t(out.size() / 3);
        break;
      }
      if (sortedKey(&out[size_t(id) * 3]) == k) {
        duplicate = true;
        break;
      }
      h = (h + 1) & (size - 1);
    }
    if (!duplicate) out.insert(out.end(), tri, tri + 3);
  }
  return out;
}

} // namespace mirage::lod::detail
