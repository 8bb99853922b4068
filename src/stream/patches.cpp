// Patch building and level selection (docs/stream.md, "Patches").
#include "mirage/stream/patches.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace mirage::stream {
namespace {

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
constexpr float kInfinity = std::numeric_limits<float>::infinity();

uint32_t corner(const Mesh& mesh, uint32_t triangle, uint32_t k) { return mesh.indices[3 * triangle + k % 3]; }

// neighbours[3 t + k]: the triangle across edge corner(k) -> corner(k + 1) of t, wound the other way
// (it holds the edge corner(k + 1) -> corner(k)); kNone on borders, non-manifold or inconsistently
// wound edges.
std::vector<uint32_t> edgeNeighbours(const Mesh& mesh) {
  uint32_t triangles = uint32_t(mesh.triangleCount());
  constexpr uint32_t kShared = kNone - 1; // a directed edge held by several triangles
  std::unordered_map<uint64_t, uint32_t> owner;
  owner.reserve(size_t(triangles) * 3);
  auto key = [](uint32_t from, uint32_t to) { return uint64_t(from) << 32 | to; };
  for (uint32_t t = 0; t < triangles; ++t) {
    for (uint32_t k = 0; k < 3; ++k) {
      auto [it, fresh] = owner.emplace(key(corner(mesh, t, k), corner(mesh, t, k + 1)), t);
      if (!fresh) it->second = kShared;
    }
  }
  std::vector<uint32_t> neighbours(size_t(triangles) * 3, kNone);
  for (uint32_t t = 0; t < triangles; ++t) {
    for (uint32_t k = 0; k < 3; ++k) {
      auto it = owner.find(key(corner(mesh, t, k + 1), corner(mesh, t, k)));
      if (it != owner.end() && it->second != kShared && it->second != t) neighbours[3 * t + k] = it->second;
    }
  }
  return neighbours;
}

float stretchOf(const Mesh& mesh, const Patch& patch) {
  glm::vec3 positions[MIRAGE_ATLAS_MAX_PATCH_VERTICES];
  patchPositions(mesh, patch, positions);
  return patchStretch(positions, patch.triangleCount);
}

// Triangle t alone with corner `rotation` as slot a.
Patch singlePatch(const Mesh& mesh, uint32_t t, uint32_t rotation) {
  Patch patch;
  for (uint32_t slot = 0; slot < 3; ++slot) patch.vertices[slot] = corner(mesh, t, rotation + slot);
  patch.vertices[MIRAGE_PATCH_D] = patch.vertices[MIRAGE_PATCH_E] = patch.vertices[MIRAGE_PATCH_A];
  patch.triangleCount = 1;
  patch.triangles[0] = patch.triangles[1] = patch.triangles[2] = t;
  return patch;
}

// t0 = t with its edge k (corner k -> k + 1) as b -> c, t1 = u (holding c -> b) as (c, b, d).
Patch pairPatch(const Mesh& mesh, uint32_t t, uint32_t k, uint32_t u) {
  Patch patch;
  uint32_t b = corner(mesh, t, k), c = corner(mesh, t, k + 1);
  patch.vertices[MIRAGE_PATCH_A] = corner(mesh, t, k + 2);
  patch.vertices[MIRAGE_PATCH_B] = b;
  patch.vertices[MIRAGE_PATCH_C] = c;
  for (uint32_t m = 0; m < 3; ++m) {
    if (corner(mesh, u, m) == c && corner(mesh, u, m + 1) == b) patch.vertices[MIRAGE_PATCH_D] = corner(mesh, u, m + 2);
  }
  patch.vertices[MIRAGE_PATCH_E] = patch.vertices[MIRAGE_PATCH_A];
  patch.triangleCount = 2;
  patch.triangles[0] = t;
  patch.triangles[1] = patch.triangles[2] = u;
  return patch;
}

// The same pair with its triangles' roles swapped: t0' = t1 = (c, b, d) read as (d, c, b), so
// a' = d, b' = c, c' = b, and t1' = t0 read as (b, c, a), d' = a.
Patch swappedPair(const Patch& pair) {
  Patch swapped = pair;
  swapped.vertices[MIRAGE_PATCH_A] = pair.vertices[MIRAGE_PATCH_D];
  swapped.vertices[MIRAGE_PATCH_B] = pair.vertices[MIRAGE_PATCH_C];
  swapped.vertices[MIRAGE_PATCH_C] = pair.vertices[MIRAGE_PATCH_B];
  swapped.vertices[MIRAGE_PATCH_D] = pair.vertices[MIRAGE_PATCH_A];
  swapped.vertices[MIRAGE_PATCH_E] = swapped.vertices[MIRAGE_PATCH_A];
  swapped.triangles[0] = pair.triangles[1];
  swapped.triangles[1] = swapped.triangles[2] = pair.triangles[0];
  return swapped;
}

// `pair` extended by triangle s as t2 = (b, e, d) when s holds the edge d -> b; otherwise `pair`
// unchanged (triangleCount stays 2).
Patch tripleOf(const Mesh& mesh, const Patch& pair, uint32_t s) {
  Patch patch = pair;
  uint32_t b = pair.vertices[MIRAGE_PATCH_B], d = pair.vertices[MIRAGE_PATCH_D];
  for (uint32_t m = 0; m < 3; ++m) {
    if (corner(mesh, s, m) == d && corner(mesh, s, m + 1) == b) {
      patch.vertices[MIRAGE_PATCH_E] = corner(mesh, s, m + 2);
      patch.triangleCount = 3;
      patch.triangles[2] = s;
    }
  }
  return patch;
}

struct PairCandidate {
  float stretch;
  uint32_t t, k, u;
};

// Smallest and largest eigenvalues of the Gram matrix of the Jacobian [x y] (squared singular values).
void gramEigen(glm::vec3 x, glm::vec3 y, float& lo, float& hi) {
  double xx = glm::dot(x, x), yy = glm::dot(y, y), xy = glm::dot(x, y);
  double trace = xx + yy, det = std::max(xx * yy - xy * xy, 0.0);
  double root = std::sqrt(std::max(trace * trace * 0.25 - det, 0.0));
  hi = std::max(hi, float(trace * 0.5 + root));
  lo = std::min(lo, float(std::max(trace * 0.5 - root, 0.0)));
}

glm::vec2 pixelOf(glm::vec4 clip, glm::uvec2 viewport) {
  glm::vec2 ndc = glm::vec2(clip) / clip.w;
  return (ndc * 0.5f + 0.5f) * glm::vec2(viewport);
}

} // namespace

float patchStretch(std::span<const glm::vec3> p, uint32_t triangleCount) {
  float lo = kInfinity, hi = 0.0f;
  gramEigen(p[MIRAGE_PATCH_B] - p[MIRAGE_PATCH_A], p[MIRAGE_PATCH_C] - p[MIRAGE_PATCH_A], lo, hi); // t0
  if (triangleCount >= 2)
    gramEigen(p[MIRAGE_PATCH_D] - p[MIRAGE_PATCH_C], p[MIRAGE_PATCH_D] - p[MIRAGE_PATCH_B], lo, hi);
  if (triangleCount >= 3)
    gramEigen(p[MIRAGE_PATCH_E] - p[MIRAGE_PATCH_B], p[MIRAGE_PATCH_D] - p[MIRAGE_PATCH_B], lo, hi);
  if (!(hi > 0.0f) || !(lo > hi * 1e-12f)) return kInfinity;
  return std::sqrt(hi / lo);
}

void patchPositions(const Mesh& mesh, const Patch& patch, glm::vec3 out[MIRAGE_ATLAS_MAX_PATCH_VERTICES]) {
  for (uint32_t v = 0; v < MIRAGE_ATLAS_MAX_PATCH_VERTICES; ++v) out[v] = mesh.positions[patch.vertices[v]];
}

MeshPatches buildMeshPatches(const Mesh& mesh) {
  uint32_t triangles = uint32_t(mesh.triangleCount());
  std::vector<uint32_t> neighbours = edgeNeighbours(mesh);

  // Each triangle alone, at its least stretched rotation.
  std::vector<Patch> single(triangles);
  std::vector<float> singleStretch(triangles, kInfinity);
  for (uint32_t t = 0; t < triangles; ++t) {
    for (uint32_t rotation = 0; rotation < 3; ++rotation) {
      Patch patch = singlePatch(mesh, t, rotation);
      float stretch = stretchOf(mesh, patch);
      if (rotation == 0 || stretch < singleStretch[t]) {
        single[t] = patch;
        singleStretch[t] = stretch;
      }
    }
  }

  // Pairs, least stretched first.
  std::vector<PairCandidate> candidates;
  for (uint32_t t = 0; t < triangles; ++t) {
    for (uint32_t k = 0; k < 3; ++k) {
      uint32_t u = neighbours[3 * t + k];
      if (u == kNone || u < t) continue;
      float stretch = stretchOf(mesh, pairPatch(mesh, t, k, u));
      if (stretch <= kMaxPairStretchGrowth * std::max(singleStretch[t], singleStretch[u])) {
        candidates.push_back({stretch, t, k, u});
      }
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const PairCandidate& x, const PairCandidate& y) { return x.stretch < y.stretch; });

  MeshPatches out;
  out.patchOfTriangle.assign(triangles, kNone);
  std::vector<float> patchStretchOf;
  for (const PairCandidate& c : candidates) {
    if (out.patchOfTriangle[c.t] != kNone || out.patchOfTriangle[c.u] != kNone) continue;
    out.patchOfTriangle[c.t] = out.patchOfTriangle[c.u] = uint32_t(out.patches.size());
    out.patches.push_back(pairPatch(mesh, c.t, c.k, c.u));
    patchStretchOf.push_back(c.stretch);
  }

  // Triangles left single join a neighbouring pair as its t2 where the winding allows, else stay single.
  for (uint32_t s = 0; s < triangles; ++s) {
    if (out.patchOfTriangle[s] != kNone) continue;
    uint32_t bestPatch = kNone;
    Patch best;
    float bestStretch = kInfinity;
    for (uint32_t k = 0; k < 3; ++k) {
      uint32_t x = neighbours[3 * s + k];
      if (x == kNone || out.patchOfTriangle[x] == kNone) continue;
      uint32_t index = out.patchOfTriangle[x];
      const Patch& pair = out.patches[index];
      if (pair.triangleCount != 2) continue;
      Patch triple = tripleOf(mesh, pair.triangles[1] == x ? pair : swappedPair(pair), s);
      if (triple.triangleCount != 3) continue;
      float stretch = stretchOf(mesh, triple);
      float limit = kMaxPairStretchGrowth * std::max(patchStretchOf[index], singleStretch[s]);
      if (stretch <= limit && (bestPatch == kNone || stretch < bestStretch)) {
        bestPatch = index;
        best = triple;
        bestStretch = stretch;
      }
    }
    if (bestPatch != kNone) {
      out.patches[bestPatch] = best;
      out.patchOfTriangle[s] = bestPatch;
    } else {
      out.patchOfTriangle[s] = uint32_t(out.patches.size());
      out.patches.push_back(single[s]);
      patchStretchOf.push_back(singleStretch[s]);
    }
  }
  return out;
}

PatchRef PatchTable::patchRef(uint32_t globalPatch) const {
  auto it = std::upper_bound(instancePatchOffset.begin(), instancePatchOffset.end(), globalPatch);
  uint32_t instance = uint32_t(it - instancePatchOffset.begin()) - 1;
  return {instance, globalPatch - instancePatchOffset[instance]};
}

uint32_t PatchTable::patchOfTriangle(uint32_t globalTriangle) const {
  auto it = std::upper_bound(instanceTriangleOffset.begin(), instanceTriangleOffset.end(), globalTriangle);
  uint32_t instance = uint32_t(it - instanceTriangleOffset.begin()) - 1;
  const MeshPatches& mesh = meshes[instanceMesh[instance]];
  return instancePatchOffset[instance] + mesh.patchOfTriangle[globalTriangle - instanceTriangleOffset[instance]];
}

PatchTable buildPatchTable(const Scene& scene) {
  PatchTable table;
  table.meshes.reserve(scene.meshes.size());
  for (const Mesh& mesh : scene.meshes) table.meshes.push_back(buildMeshPatches(mesh));
  uint32_t patches = 0, triangles = 0;
  for (const Instance& instance : scene.instances) {
    table.instanceMesh.push_back(instance.mesh);
    table.instancePatchOffset.push_back(patches);
    table.instanceTriangleOffset.push_back(triangles);
    patches += uint32_t(table.meshes[instance.mesh].patches.size());
    triangles += uint32_t(scene.meshes[instance.mesh].triangleCount());
  }
  table.instancePatchOffset.push_back(patches);
  table.instanceTriangleOffset.push_back(triangles);
  return table;
}

void patchWorldPositions(const Scene& scene, const PatchTable& table, uint32_t globalPatch,
                         glm::vec3 out[MIRAGE_ATLAS_MAX_PATCH_VERTICES]) {
  PatchRef ref = table.patchRef(globalPatch);
  const Instance& instance = scene.instances[ref.instance];
  patchPositions(scene.meshes[instance.mesh], table.patch(ref), out);
  for (uint32_t v = 0; v < MIRAGE_ATLAS_MAX_PATCH_VERTICES; ++v) {
    out[v] = glm::vec3(instance.transform * glm::vec4(out[v], 1.0f));
  }
}

float patchProjectedLength(std::span<const glm::vec3> world, uint32_t triangleCount, const glm::mat4& viewProj,
                           glm::uvec2 viewport) {
  uint32_t slots = triangleCount == 1 ? 3u : (triangleCount == 2 ? 4u : 5u);
  glm::vec2 pixel[MIRAGE_ATLAS_MAX_PATCH_VERTICES]{};
  for (uint32_t v = 0; v < slots; ++v) {
    glm::vec4 clip = viewProj * glm::vec4(world[v], 1.0f);
    if (!(clip.w > 0.0f)) return kInfinity;
    pixel[v] = pixelOf(clip, viewport);
  }
  auto edge = [&](uint32_t from, uint32_t to) { return glm::length(pixel[to] - pixel[from]); };
  const float diagonal = 1.0f / std::sqrt(2.0f);
  float length = std::max({edge(MIRAGE_PATCH_A, MIRAGE_PATCH_B), edge(MIRAGE_PATCH_A, MIRAGE_PATCH_C),
                           edge(MIRAGE_PATCH_B, MIRAGE_PATCH_C) * diagonal});
  if (triangleCount >= 2) {
    length = std::max({length, edge(MIRAGE_PATCH_C, MIRAGE_PATCH_D), edge(MIRAGE_PATCH_B, MIRAGE_PATCH_D)});
  }
  if (triangleCount >= 3) {
    length = std::max({length, edge(MIRAGE_PATCH_B, MIRAGE_PATCH_E), edge(MIRAGE_PATCH_E, MIRAGE_PATCH_D) * diagonal});
  }
  return length;
}

uint32_t blockLog2ForLength(float length, uint32_t triangleCount, float bias) {
  uint32_t maxLog2 = maxBlockLog2(triangleCount);
  float texels = length * std::exp2(bias) + 1.0f;
  if (!std::isfinite(texels)) return maxLog2;
  float wanted = std::ceil(std::log2(std::max(texels, 1.0f)));
  return uint32_t(std::clamp(wanted, float(MIRAGE_ATLAS_MIN_BLOCK_LOG2), float(maxLog2)));
}

uint32_t patchBlockLog2(std::span<const glm::vec3> world, uint32_t triangleCount, const glm::mat4& viewProj,
                        glm::uvec2 viewport, float bias) {
  return blockLog2ForLength(patchProjectedLength(world, triangleCount, viewProj, viewport), triangleCount, bias);
}

float fitLevelBias(std::span<const PatchExtent> patches, float bias, uint64_t budgetTexels) {
  auto texelsAt = [&](float b) {
    uint64_t total = 0;
    for (const PatchExtent& p : patches)
      total += blockTexels(blockLog2ForLength(p.length, p.triangleCount, b), p.triangleCount);
    return total;
  };
  if (texelsAt(bias) <= budgetTexels) return bias;
  // Quarter levels down: at k = kLast every finite length L has L 2^(bias - k / 4) <= 1, the smallest level.
  float longest = 1.0f;
  for (const PatchExtent& p : patches)
    if (std::isfinite(p.length)) longest = std::max(longest, p.length);
  uint32_t last = uint32_t(std::max(0.0f, std::ceil(4.0f * (bias + std::log2(longest))))) + 1;
  uint32_t lo = 0, hi = last; // texelsAt(bias - lo / 4) > budget; at hi: fits, or the floor
  while (hi - lo > 1) {
    uint32_t mid = lo + (hi - lo) / 2;
    (texelsAt(bias - float(mid) * 0.25f) <= budgetTexels ? hi : lo) = mid;
  }
  return bias - float(hi) * 0.25f;
}

} // namespace mirage::stream
