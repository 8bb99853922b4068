// Tessellation of large triangles at scene load (tessellate.h; docs/stream.md, "Tessellation").
#include "mirage/stream/tessellate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include <fmt/format.h>

namespace mirage::stream {
namespace {

constexpr float kInfinity = std::numeric_limits<float>::infinity();
// Triangle and vertex indices stay 32-bit (PatchTable's global ids too).
constexpr uint64_t kMaxTriangles = uint64_t(1) << 31;

// Squared length in double of the float difference: the same bits whichever way the edge is read
// (q - p is exactly -(p - q), and squares lose the sign).
double squaredLength(glm::vec3 p, glm::vec3 q) {
  glm::dvec3 d = glm::dvec3(q - p);
  return d.x * d.x + d.y * d.y + d.z * d.z;
}

bool finite(glm::vec3 p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// The refinement of one mesh: source attributes copied, new vertices appended by `splitVertex`.
class Refiner {
public:
  Refiner(const Mesh& source, float maxEdge)
      : out_(source), maxEdge_(maxEdge), limit_(double(maxEdge) * double(maxEdge)) {
    out_.indices.clear();
    splits_.reserve(source.triangleCount());
  }

  // Splits source triangle (a, b, c) until no edge is longer than the limit. Errors: a non-finite
  // position on an edge to split; more than maxTriangles triangles in the mesh (overLimit set).
  Status refine(uint32_t a, uint32_t b, uint32_t c, uint32_t source, uint64_t maxTriangles,
                std::vector<uint32_t>* sourceTriangle, bool& overLimit) {
    stack_.clear();
    stack_.push_back(Triangle{{a, b, c}});
    while (!stack_.empty()) {
      Triangle t = stack_.back();
      stack_.pop_back();
      // The longest edge that must and can be split (splitOf: decided by the edge alone).
      int split = -1;
      double longest = 0.0;
      Split how;
      for (int k = 0; k < 3; ++k) {
        uint32_t p = t.v[k], q = t.v[(k + 1) % 3];
        double length = squaredLength(out_.positions[p], out_.positions[q]);
        if (!(length > limit_ && length > longest)) continue;
        if (!finite(out_.positions[p]) || !finite(out_.positions[q]))
          return Error{fmt::format("triangle {} has a non-finite vertex position", source)};
        if (auto s = splitOf(p, q)) {
          split = k;
          longest = length;
          how = *s;
        }
      }
      if (split < 0) {
        out_.indices.insert(out_.indices.end(), {t.v[0], t.v[1], t.v[2]});
        if (sourceTriangle) sourceTriangle->push_back(source);
      } else {
        // (p, q, r) with p -> q the longest edge: (p, m, r) and (m, q, r) keep the winding.
        uint32_t p = t.v[split], q = t.v[(split + 1) % 3], r = t.v[(split + 2) % 3];
        uint32_t m = splitVertex(how);
        stack_.push_back(Triangle{{m, q, r}});
        stack_.push_back(Triangle{{p, m, r}});
      }
      if (out_.indices.size() / 3 + stack_.size() > maxTriangles) {
        overLimit = true;
        return Error{fmt::format("more than {} triangles", maxTriangles)};
      }
    }
    return Ok{};
  }

  Mesh take() { return std::move(out_); }

private:
  struct Triangle {
    uint32_t v[3];
  };

  // Where edge (p, q) is split: from its origin (the endpoint with the lexicographically smaller
  // position, so both triangles holding the edge agree, whichever way they read it), at the fraction
  // t = floor(n / 2) / n of the way to the other end, n = ceil(length / maxEdge): the edge ends in n
  // pieces of length / n, its fewest within the limit. None when n < 2 or the point rounds onto an
  // endpoint (float precision).
  struct Split {
    uint32_t origin = 0, other = 0;
    float t = 0.0f;
    glm::vec3 position{0.0f};
  };
  std::optional<Split> splitOf(uint32_t p, uint32_t q) const {
    glm::vec3 a = out_.positions[p], b = out_.positions[q];
    bool pFirst = a.x != b.x ? a.x < b.x : (a.y != b.y ? a.y < b.y : a.z < b.z);
    Split s{pFirst ? p : q, pFirst ? q : p};
    double pieces = std::ceil(std::sqrt(squaredLength(a, b)) / maxEdge_);
    if (!(pieces >= 2.0)) return std::nullopt;
    s.t = float(std::floor(pieces * 0.5) / pieces);
    glm::vec3 from = out_.positions[s.origin], to = out_.positions[s.other];
    s.position = from + (to - from) * s.t;
    if (s.position == from || s.position == to) return std::nullopt;
    return s;
  }

  // The vertex at `split`, made once per edge (edges shared by index share it): every attribute is
  // interpolated along the edge, which is the source triangle's barycentric interpolation.
  uint32_t splitVertex(const Split& split) {
    uint32_t o = split.origin, x = split.other;
    uint64_t key = uint64_t(std::min(o, x)) << 32 | std::max(o, x);
    auto [it, fresh] = splits_.emplace(key, uint32_t(out_.positions.size()));
    if (!fresh) return it->second;
    out_.positions.push_back(split.position);
    auto lerp = [&](auto& attribute) {
      if (!attribute.empty()) attribute.push_back(attribute[o] + (attribute[x] - attribute[o]) * split.t);
    };
    lerp(out_.normals);
    lerp(out_.tangents);
    lerp(out_.uv0);
    lerp(out_.colors);
    return it->second;
  }

  Mesh out_;
  double maxEdge_, limit_; // the limit and its square
  std::unordered_map<uint64_t, uint32_t> splits_;
  std::vector<Triangle> stack_;
};

Result<Mesh> refineCounted(const Mesh& mesh, float maxEdge, uint64_t maxTriangles,
                           std::vector<uint32_t>* sourceTriangle, bool& overLimit) {
  overLimit = false;
  if (sourceTriangle) sourceTriangle->clear();
  if (mesh.triangleCount() > maxTriangles) {
    overLimit = true;
    return Error{fmt::format("mesh '{}': more than {} triangles", mesh.name, maxTriangles)};
  }
  Refiner refiner(mesh, maxEdge);
  for (uint32_t t = 0; t < mesh.triangleCount(); ++t) {
    const uint32_t* v = &mesh.indices[3 * size_t(t)];
    if (auto s = refiner.refine(v[0], v[1], v[2], t, maxTriangles, sourceTriangle, overLimit); !s)
      return Error{fmt::format("mesh '{}': {}", mesh.name, s.error().message)};
  }
  return refiner.take();
}

} // namespace

float patchEdgeLength(const Scene& scene, const TessellationConfig& config) {
  if (config.maxPatchEdge > 0.0f) return config.maxPatchEdge;
  Bounds bounds = scene.worldBounds();
  float diagonal = bounds.empty() ? 0.0f : glm::length(bounds.extent());
  return diagonal > 0.0f ? diagonal / kPatchEdgeDivisions : kInfinity;
}

Result<Mesh> refineMesh(const Mesh& mesh, float maxEdge, uint64_t maxTriangles, std::vector<uint32_t>* sourceTriangle) {
  bool overLimit = false;
  return refineCounted(mesh, maxEdge, std::min(maxTriangles, kMaxTriangles), sourceTriangle, overLimit);
}

Result<TessellationStats> tessellateScene(Scene& scene, const TessellationConfig& config) {
  if (std::isnan(config.maxPatchEdge) || config.maxPatchEdge < 0.0f)
    return Error{fmt::format("max patch edge {} must be >= 0 (0: the scene's diagonal / {}, inf: no tessellation)",
                             config.maxPatchEdge, kPatchEdgeDivisions)};
  if (config.maxTriangles == 0 || config.maxTriangles > kMaxTriangles)
    return Error{fmt::format("max triangles {} must be in 1..{}", config.maxTriangles, kMaxTriangles)};
  TessellationStats stats;
  stats.maxPatchEdge = patchEdgeLength(scene, config);
  stats.trianglesBefore = stats.trianglesAfter = scene.instancedTriangleCount();
  if (stats.trianglesBefore > config.maxTriangles)
    return Error{fmt::format("{} triangles, more than the limit of {}", stats.trianglesBefore, config.maxTriangles)};
  if (!std::isfinite(stats.maxPatchEdge)) return stats;

  // Per mesh: its instances and how far they stretch it.
  std::vector<uint64_t> instances(scene.meshes.size(), 0);
  std::vector<float> scale(scene.meshes.size(), 0.0f);
  for (const Instance& instance : scene.instances) {
    instances[instance.mesh]++;
    scale[instance.mesh] = std::max(scale[instance.mesh], maxAxisScale(instance.transform));
  }
  // Meshes are refined in order; each may grow to what the limit leaves once the meshes after it
  // are counted at their source size (they only grow).
  uint64_t rest = stats.trianglesBefore;
  stats.trianglesAfter = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    Mesh& mesh = scene.meshes[m];
    if (instances[m] == 0) continue;
    rest -= instances[m] * mesh.triangleCount();
    uint64_t budget = (config.maxTriangles - rest - stats.trianglesAfter) / instances[m];
    if (scale[m] > 0.0f && std::isfinite(scale[m])) {
      bool overLimit = false;
      auto refined = refineCounted(mesh, stats.maxPatchEdge / scale[m], budget, nullptr, overLimit);
      if (!refined && overLimit)
        return Error{fmt::format("tessellation to edges of at most {:g} would give more than the limit of {} "
                                 "triangles (a larger max patch edge or triangle limit)",
                                 stats.maxPatchEdge, config.maxTriangles)};
      if (!refined) return Error{fmt::format("tessellation: {}", refined.error().message)};
      mesh = std::move(*refined);
    }
    stats.trianglesAfter += instances[m] * mesh.triangleCount();
  }
  return stats;
}

} // namespace mirage::stream
