#include "mirage/lod/verify.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mesh_prep.h"

namespace mirage::lod {

namespace {

using detail::edgeKey;

// Simplifying the mesh's own open border (ears at corners, holes closing) legitimately changes
// area, so this only catches gross errors; covering a region twice at least doubles it.
constexpr float kAreaTolerance = 0.5f;

Error fail(const std::string& what) { return makeError("cluster dag", what); }

template <class F> void forClusterTriangles(const ClusterDag& dag, uint32_t c, F&& f) {
  const Cluster& cl = dag.clusters[c];
  const uint32_t* v = &dag.clusterVertices[cl.vertexOffset];
  const uint8_t* idx = &dag.clusterIndices[size_t(cl.triangleOffset) * 3];
  for (uint32_t t = 0; t < cl.triangleCount; ++t)
    f(dag.vertexPosition[v[idx[t * 3]]], dag.vertexPosition[v[idx[t * 3 + 1]]], dag.vertexPosition[v[idx[t * 3 + 2]]]);
}

float triangleArea(const std::vector<glm::vec3>& p, uint32_t a, uint32_t b, uint32_t c) {
  return 0.5f * glm::length(glm::cross(p[b] - p[a], p[c] - p[a]));
}

// Welded edges of a set of clusters, sorted, with multiplicity; adds their area.
std::vector<uint64_t> clusterEdges(const ClusterDag& dag, const uint32_t* ids, size_t count, double& area) {
  std::vector<uint64_t> edges;
  for (size_t i = 0; i < count; ++i)
    forClusterTriangles(dag, ids[i], [&](uint32_t a, uint32_t b, uint32_t c) {
      edges.insert(edges.end(), {edgeKey(a, b), edgeKey(b, c), edgeKey(c, a)});
      area += triangleArea(dag.positions, a, b, c);
    });
  std::sort(edges.begin(), edges.end());
  return edges;
}

// Edges used exactly once.
std::vector<uint64_t> openEdges(const std::vector<uint64_t>& sorted) {
  std::vector<uint64_t> open;
  for (size_t i = 0; i < sorted.size();) {
    size_t j = i;
    while (j < sorted.size() && sorted[j] == sorted[i]) ++j;
    if (j - i == 1) open.push_back(sorted[i]);
    i = j;
  }
  return open;
}

bool contains(const LodBounds& outer, const LodBounds& inner) {
  float slack = 1e-4f * outer.radius + 1e-6f;
  return glm::distance(outer.center, inner.center) + inner.radius <= outer.radius + slack;
}

std::string str(uint64_t v) { return std::to_string(v); }

} // namespace

Status checkDagStructure(const ClusterDag& dag) {
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const Cluster& cl = dag.clusters[c];
    if (size_t(cl.vertexOffset) + cl.vertexCount > dag.clusterVertices.size() ||
        (size_t(cl.triangleOffset) + cl.triangleCount) * 3 > dag.clusterIndices.size())
      return fail("cluster " + str(c) + " range out of bounds");
    if (cl.triangleCount == 0 || cl.vertexCount > 255) return fail("cluster " + str(c) + " has a bad size");
    for (uint32_t v = 0; v < cl.vertexCount; ++v)
      if (dag.clusterVertices[cl.vertexOffset + v] >= dag.vertexPosition.size())
        return fail("cluster " + str(c) + " references a missing vertex");
    for (uint32_t i = 0; i < cl.triangleCount * 3u; ++i)
      if (dag.clusterIndices[size_t(cl.triangleOffset) * 3 + i] >= cl.vertexCount)
        return fail("cluster " + str(c) + " local index out of range");
    if ((cl.level == 0) != (cl.generatingGroup == kNone)) return fail("cluster " + str(c) + " level/group mismatch");
    if (cl.group != kNone && cl.group >= dag.groups.size()) return fail("cluster " + str(c) + " bad group");
    if (cl.generatingGroup != kNone && cl.generatingGroup >= dag.groups.size())
      return fail("cluster " + str(c) + " bad generating group");
    if (c > 0 && cl.level < dag.clusters[c - 1].level) return fail("cluster " + str(c) + " is out of level order");
  }
  for (uint32_t p : dag.vertexPosition)
    if (p >= dag.positions.size()) return fail("vertex position out of range");
  for (size_t n : {dag.normals.size(), dag.uv0.size()})
    if (n != 0 && n != dag.vertexPosition.size()) return fail("attribute count differs from the vertex count");
  // Links both ways, each cluster in at most one group as a child and as a parent, parents one
  // level above their group and children at most at it: group levels then strictly grow along
  // every child -> parent path, so the group graph has no cycle (renderers walk it).
  std::vector<uint32_t> childCount(dag.clusters.size(), 0), parentCount(dag.clusters.size(), 0);
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    const Group& gr = dag.groups[g];
    if (size_t(gr.childOffset) + gr.childCount > dag.groupChildren.size() ||
        size_t(gr.parentOffset) + gr.parentCount > dag.groupParents.size() || gr.childCount == 0 || gr.parentCount == 0)
      return fail("group " + str(g) + " range out of bounds or empty");
    for (uint32_t i = 0; i < gr.childCount; ++i) {
      uint32_t c = dag.groupChildren[gr.childOffset + i];
      if (c >= dag.clusters.size()) return fail("group " + str(g) + " bad child");
      if (dag.clusters[c].group != g) return fail("group " + str(g) + " child " + str(c) + " does not point back");
      if (dag.clusters[c].level > gr.level) return fail("group " + str(g) + " child " + str(c) + " above its level");
      ++childCount[c];
    }
    for (uint32_t i = 0; i < gr.parentCount; ++i) {
      uint32_t c = dag.groupParents[gr.parentOffset + i];
      if (c >= dag.clusters.size()) return fail("group " + str(g) + " bad parent");
      if (dag.clusters[c].generatingGroup != g) return fail("group " + str(g) + " parent " + str(c) + " mismatch");
      if (dag.clusters[c].level != gr.level + 1)
        return fail("group " + str(g) + " parent " + str(c) + " not one level above");
      ++parentCount[c];
    }
  }
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const Cluster& cl = dag.clusters[c];
    if (childCount[c] != (cl.group != kNone ? 1u : 0u)) return fail("cluster " + str(c) + " listed in wrong groups");
    if (parentCount[c] != (cl.generatingGroup != kNone ? 1u : 0u))
      return fail("cluster " + str(c) + " listed as parent in wrong groups");
  }
  size_t rootCount = 0;
  for (const Cluster& cl : dag.clusters) rootCount += cl.group == kNone;
  if (rootCount != dag.roots.size()) return fail("root list does not match clusters without a group");
  for (uint32_t r : dag.roots)
    if (r >= dag.clusters.size() || dag.clusters[r].group != kNone) return fail("root list names a non-root cluster");
  return Ok{};
}

Status verifyDag(const ClusterDag& dag) {
  if (Status s = checkDagStructure(dag); !s) return s;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const Cluster& cl = dag.clusters[c];
    if (!(cl.self.error <= cl.parent.error)) return fail("cluster " + str(c) + " error decreases towards its parents");
    if (cl.group == kNone && !std::isinf(cl.parent.error)) return fail("root cluster " + str(c) + " has finite error");
  }
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    const Group& gr = dag.groups[g];
    for (uint32_t i = 0; i < gr.childCount; ++i) {
      uint32_t c = dag.groupChildren[gr.childOffset + i];
      const Cluster& cl = dag.clusters[c];
      if (cl.parent.error != gr.bounds.error) return fail("cluster " + str(c) + " parent error differs from its group");
      if (gr.bounds.error < cl.self.error) return fail("group " + str(g) + " error below child " + str(c));
      if (!contains(gr.bounds, cl.self)) return fail("group " + str(g) + " sphere does not contain child " + str(c));
    }
    for (uint32_t i = 0; i < gr.parentCount; ++i) {
      uint32_t c = dag.groupParents[gr.parentOffset + i];
      if (dag.clusters[c].self.error != gr.bounds.error) return fail("cluster " + str(c) + " error differs from group");
    }
  }

  // The mesh's own open border, from the level-0 clusters (they are the cleaned input).
  std::vector<uint32_t> level0;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c)
    if (dag.clusters[c].level == 0) level0.push_back(c);
  double ignored = 0.0;
  std::vector<uint8_t> onBorder(dag.positions.size(), 0);
  for (uint64_t e : openEdges(clusterEdges(dag, level0.data(), level0.size(), ignored)))
    onBorder[uint32_t(e >> 32)] = onBorder[uint32_t(e)] = 1;
  auto interior = [&](const std::vector<uint64_t>& open) {
    std::vector<uint64_t> out;
    for (uint64_t e : open)
      if (!onBorder[uint32_t(e >> 32)] || !onBorder[uint32_t(e)]) out.push_back(e);
    return out;
  };
  // Each group's parents replace exactly its children: same outer border, about the same area.
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    const Group& gr = dag.groups[g];
    double childArea = 0.0, parentArea = 0.0;
    auto childEdges = clusterEdges(dag, &dag.groupChildren[gr.childOffset], gr.childCount, childArea);
    auto parentEdges = clusterEdges(dag, &dag.groupParents[gr.parentOffset], gr.parentCount, parentArea);
    if (interior(openEdges(childEdges)) != interior(openEdges(parentEdges)))
      return fail("group " + str(g) + " parents do not keep the group border");
    for (size_t i = 0; i < parentEdges.size();) {
      size_t j = i;
      while (j < parentEdges.size() && parentEdges[j] == parentEdges[i]) ++j;
      auto r = std::equal_range(childEdges.begin(), childEdges.end(), parentEdges[i]);
      if (j - i > 2 && j - i > size_t(r.second - r.first))
        return fail("group " + str(g) + " parents fold: an edge is used by " + str(j - i) + " triangles");
      i = j;
    }
    bool touchesMeshBorder = false;
    for (uint64_t e : openEdges(childEdges)) touchesMeshBorder |= onBorder[uint32_t(e >> 32)] && onBorder[uint32_t(e)];
    // Sliding the mesh's own border vertices may remove a lot of area; only closed patches must keep it.
    if (!touchesMeshBorder && std::abs(childArea - parentArea) > kAreaTolerance * childArea + 1e-12)
      return fail("group " + str(g) + " area changes from " + std::to_string(childArea) + " to " +
                  std::to_string(parentArea));
  }
  return Ok{};
}

std::vector<uint32_t> selectCut(const ClusterDag& dag, float threshold) {
  std::vector<uint32_t> cut;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const Cluster& cl = dag.clusters[c];
    if (cl.self.error <= threshold && threshold < cl.parent.error) cut.push_back(c);
  }
  return cut;
}

Status verifyCut(const ClusterDag& dag, const std::vector<uint32_t>& cut, const Mesh& original) {
  detail::Welded w = detail::weldPositions(original.positions);
  if (w.positions != dag.positions) return fail("positions do not match the original mesh");
  std::vector<uint32_t> tris = detail::cleanTriangles(original.indices, w.vertexPosition);
  std::vector<uint64_t> origEdges;
  double origArea = 0.0;
  for (size_t t = 0; t < tris.size(); t += 3) {
    uint32_t a = w.vertexPosition[tris[t]], b = w.vertexPosition[tris[t + 1]], c = w.vertexPosition[tris[t + 2]];
    origEdges.insert(origEdges.end(), {edgeKey(a, b), edgeKey(b, c), edgeKey(c, a)});
    origArea += triangleArea(w.positions, a, b, c);
  }
  std::sort(origEdges.begin(), origEdges.end());
  std::vector<uint8_t> onBorder(w.positions.size(), 0);
  for (uint64_t e : openEdges(origEdges)) onBorder[uint32_t(e >> 32)] = onBorder[uint32_t(e)] = 1;

  std::vector<uint8_t> inCut(dag.clusters.size(), 0);
  for (uint32_t c : cut) {
    if (c >= dag.clusters.size() || inCut[c]) return fail("cut lists cluster " + str(c) + " twice or out of range");
    inCut[c] = 1;
  }
  // No cluster together with one of its ancestors (groups are stored children-first).
  std::vector<uint8_t> below(dag.clusters.size(), 0); // in the cut or has a descendant in it
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) below[c] = inCut[c];
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    const Group& gr = dag.groups[g];
    bool any = false;
    for (uint32_t i = 0; i < gr.childCount; ++i) any |= below[dag.groupChildren[gr.childOffset + i]] != 0;
    for (uint32_t i = 0; i < gr.parentCount && any; ++i) {
      uint32_t p = dag.groupParents[gr.parentOffset + i];
      if (inCut[p]) return fail("cut draws cluster " + str(p) + " and one of its descendants (overlap)");
      below[p] = 1;
    }
  }

  double area = 0.0;
  std::vector<uint64_t> edges = clusterEdges(dag, cut.data(), cut.size(), area);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    uint32_t a = uint32_t(edges[i] >> 32), b = uint32_t(edges[i]);
    if (a == b) return fail("cut has a triangle with a repeated position");
    if (j - i == 1 && (!onBorder[a] || !onBorder[b]))
      return fail("crack: open edge " + str(a) + "-" + str(b) + " is not on the mesh border");
    if (j - i > 2) {
      auto r = std::equal_range(origEdges.begin(), origEdges.end(), edges[i]);
      if (size_t(r.second - r.first) < j - i)
        return fail("overlap: edge " + str(a) + "-" + str(b) + " used by " + str(j - i) + " triangles");
    }
    i = j;
  }
  // Twice-covered regions add area; a closed mesh must also not lose much (holes would).
  bool closed = openEdges(origEdges).empty();
  if (area > (1.0 + kAreaTolerance) * origArea + 1e-12 || (closed && area < (1.0 - kAreaTolerance) * origArea))
    return fail("cut area " + std::to_string(area) + " vs original " + std::to_string(origArea));
  return Ok{};
}

} // namespace mirage::lod
