#include "lod_meshes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>

namespace mirage::lodtest {

namespace {

// Smooth deterministic bumps: a few sines in random directions.
struct Bumps {
  glm::vec3 dir[6];
  float freq[6], phase[6];
  explicit Bumps(uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int i = 0; i < 6; ++i) {
      dir[i] = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)) + glm::vec3(1e-3f));
      freq[i] = 2.0f + 6.0f * std::abs(u(rng));
      phase[i] = 3.0f * u(rng);
    }
  }
  float operator()(glm::vec3 p) const {
    float h = 0.0f;
    for (int i = 0; i < 6; ++i) h += std::sin(glm::dot(dir[i], p) * freq[i] + phase[i]) / float(i + 2);
    return h;
  }
};

void finish(Mesh& m) {
  m.bounds = Bounds{};
  for (glm::vec3 p : m.positions) m.bounds.add(p);
  if (m.normals.size() != m.positions.size()) {
    m.normals.assign(m.positions.size(), glm::vec3(0.0f));
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      glm::vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
      glm::vec3 n = glm::cross(b - a, c - a);
      for (int k = 0; k < 3; ++k) m.normals[m.indices[t + k]] += n;
    }
    for (glm::vec3& n : m.normals) n = glm::length(n) > 0.0f ? glm::normalize(n) : glm::vec3(0, 0, 1);
  }
}

} // namespace

Mesh makeBlob(uint32_t subdivisions, uint32_t seed) {
  Mesh m;
  m.name = "blob";
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  m.positions = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  m.indices = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,  11, 10, 2,  10, 7, 6, 7, 1, 8,
               3, 9,  4, 3, 4, 2, 3, 2, 6, 3, 6, 8,  3, 8,  9,  4, 9, 5, 2, 4,  11, 6,  2,  10, 8,  6, 7, 9, 8, 1};
  for (uint32_t s = 0; s < subdivisions; ++s) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      uint32_t id = uint32_t(m.positions.size());
      m.positions.push_back((m.positions[a] + m.positions[b]) * 0.5f);
      mid[key] = id;
      return id;
    };
    std::vector<uint32_t> next;
    for (size_t i = 0; i < m.indices.size(); i += 3) {
      uint32_t a = m.indices[i], b = m.indices[i + 1], c = m.indices[i + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    m.indices = std::move(next);
  }
  Bumps bumps(seed);
  for (glm::vec3& p : m.positions) {
    glm::vec3 n = glm::normalize(p);
    p = n * (1.0f + 0.15f * bumps(n));
  }
  finish(m);
  return m;
}

Mesh makeTerrain(uint32_t n, uint32_t seed) {
  Mesh m;
  m.name = "terrain";
  Bumps bumps(seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
  for (uint32_t y = 0; y <= n; ++y)
    for (uint32_t x = 0; x <= n; ++x) {
      glm::vec3 p{float(x) / float(n) * 4.0f - 2.0f, 0.0f, float(y) / float(n) * 4.0f - 2.0f};
      p.y = 0.3f * bumps(p * 0.5f) + jitter(rng);
      m.positions.push_back(p);
      m.uv0.push_back({float(x) / float(n), float(y) / float(n)});
    }
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  finish(m);
  return m;
}

Mesh makeSeamBlob(uint32_t subdivisions, uint32_t seed) {
  Mesh blob = makeBlob(subdivisions, seed);
  Mesh m;
  m.name = "seam-blob";
  std::map<std::pair<uint32_t, int>, uint32_t> wedge; // (position vertex, chart) -> new vertex
  for (size_t i = 0; i < blob.indices.size(); i += 3) {
    glm::vec3 c =
        (blob.positions[blob.indices[i]] + blob.positions[blob.indices[i + 1]] + blob.positions[blob.indices[i + 2]]);
    glm::vec3 a = glm::abs(c);
    int axis = a.x > a.y && a.x > a.z ? 0 : a.y > a.z ? 1 : 2;
    int chart = axis * 2 + (c[axis] < 0.0f);
    for (int k = 0; k < 3; ++k) {
      uint32_t v = blob.indices[i + k];
      auto [it, fresh] = wedge.try_emplace({v, chart}, uint32_t(m.positions.size()));
      if (fresh) {
        glm::vec3 p = blob.positions[v];
        m.positions.push_back(p);
        m.normals.push_back(glm::normalize(blob.normals[v] + glm::vec3(0.05f * float(chart))));
        m.uv0.push_back({p[(axis + 1) % 3] * 0.5f + float(chart), p[(axis + 2) % 3] * 0.5f});
      }
      m.indices.push_back(it->second);
    }
  }
  finish(m);
  return m;
}

Mesh makeRandomMesh(uint32_t seed) {
  std::mt19937 rng(seed);
  auto uni = [&](uint32_t lo, uint32_t hi) { return std::uniform_int_distribution<uint32_t>(lo, hi)(rng); };
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  Mesh m;
  m.name = "random-" + std::to_string(seed);
  uint32_t n = uni(3, 24);
  for (uint32_t y = 0; y <= n; ++y)
    for (uint32_t x = 0; x <= n; ++x)
      m.positions.push_back({float(x) + 0.3f * u01(rng), 0.5f * u01(rng), float(y) + 0.3f * u01(rng)});
  float holes = 0.3f * u01(rng);
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      if (u01(rng) >= holes) m.indices.insert(m.indices.end(), {a, c, b});
      if (u01(rng) >= holes) m.indices.insert(m.indices.end(), {b, c, d});
    }
  uint32_t extras = uni(0, 8);
  for (uint32_t i = 0; i < extras && !m.indices.empty(); ++i) {
    size_t t = uni(0, uint32_t(m.indices.size() / 3 - 1)) * 3;
    uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
    switch (uni(0, 4)) {
    case 0:
      m.indices.insert(m.indices.end(), {a, b, c});
      break; // duplicate
    case 1:
      m.indices.insert(m.indices.end(), {a, c, b});
      break; // duplicate, flipped
    case 2:
      m.indices.insert(m.indices.end(), {a, a, b});
      break;  // zero area
    case 3: { // non-manifold fin on edge a-b
      m.positions.push_back((m.positions[a] + m.positions[b]) * 0.5f + glm::vec3(0, 1, 0));
      m.indices.insert(m.indices.end(), {a, b, uint32_t(m.positions.size() - 1)});
      break;
    }
    default:
      m.positions.push_back(m.positions[a]); // same position, new vertex: a seam wedge
      m.indices.insert(m.indices.end(), {uint32_t(m.positions.size() - 1), b, c});
    }
  }
  if (uni(0, 1)) m.positions.push_back({100.0f, 0.0f, 0.0f}); // isolated vertex
  if (uni(0, 1)) {                                            // disconnected tetrahedron
    uint32_t o = uint32_t(m.positions.size());
    m.positions.insert(m.positions.end(), {{-5, 0, -5}, {-4, 0, -5}, {-5, 0, -4}, {-5, 1, -5}});
    m.indices.insert(m.indices.end(), {o, o + 2, o + 1, o, o + 1, o + 3, o + 1, o + 2, o + 3, o + 2, o, o + 3});
  }
  finish(m);
  return m;
}

Mesh makeDrilledSlab() {
  Mesh m;
  m.name = "drilled slab";
  constexpr int kSide = 40, kDepth = 6;
  auto solid = [](int x, int y, int z) {
    if (x < 0 || y < 0 || z < 0 || x >= kSide || y >= kSide || z >= kDepth) return false;
    return !(x % 10 == 5 && y % 10 == 5); // the holes
  };
  std::map<std::array<int, 3>, uint32_t> corner;
  auto vertex = [&](int x, int y, int z) {
    auto [it, added] = corner.try_emplace({x, y, z}, uint32_t(m.positions.size()));
    if (added) m.positions.push_back(glm::vec3(float(x), float(y), float(z)) * 0.1f);
    return it->second;
  };
  // One outward quad per voxel face with an empty neighbour.
  const int dirs[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int z = 0; z < kDepth; ++z)
    for (int y = 0; y < kSide; ++y)
      for (int x = 0; x < kSide; ++x) {
        if (!solid(x, y, z)) continue;
        for (const int* d : dirs) {
          if (solid(x + d[0], y + d[1], z + d[2])) continue;
          int axis = d[0] ? 0 : d[1] ? 1 : 2, sign = d[axis];
          int u = (axis + 1) % 3, v = (axis + 2) % 3;
          std::array<int, 3> base{x, y, z};
          if (sign > 0) base[axis] += 1;
          uint32_t q[4];
          for (int k = 0; k < 4; ++k) {
            std::array<int, 3> c = base;
            c[u] += (k == 1 || k == 2), c[v] += (k >= 2);
            q[k] = vertex(c[0], c[1], c[2]);
          }
          if (sign > 0)
            m.indices.insert(m.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
          else
            m.indices.insert(m.indices.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
        }
      }
  finish(m);
  return m;
}

std::optional<Mesh> readAsciiPly(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::string line, word;
  size_t vertices = 0, faces = 0, vertexProps = 0;
  bool inVertex = false;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    ls >> word;
    if (word == "format" && line.find("ascii") == std::string::npos) return std::nullopt;
    if (word == "element") {
      std::string kind;
      size_t count = 0;
      ls >> kind >> count;
      inVertex = kind == "vertex";
      (inVertex ? vertices : faces) = count;
    } else if (word == "property" && inVertex) {
      ++vertexProps;
    } else if (word == "end_header") {
      break;
    }
  }
  Mesh m;
  m.name = path.filename().string();
  m.positions.resize(vertices);
  for (size_t i = 0; i < vertices; ++i) {
    float skip;
    in >> m.positions[i].x >> m.positions[i].y >> m.positions[i].z;
    for (size_t p = 3; p < vertexProps; ++p) in >> skip;
  }
  for (size_t f = 0; f < faces; ++f) {
    uint32_t n = 0, first = 0, prev = 0, v = 0;
    in >> n;
    for (uint32_t k = 0; k < n; ++k) {
      in >> v;
      if (k == 0) first = v;
      if (k >= 2) m.indices.insert(m.indices.end(), {first, prev, v});
      prev = v;
    }
  }
  if (!in) return std::nullopt;
  finish(m);
  return m;
}

} // namespace mirage::lodtest
