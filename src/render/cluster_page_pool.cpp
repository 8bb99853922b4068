// The cluster renderer's side of paged assets (docs/render.md, "Residency"): the scene tables made
// from the page tables alone, and the layout of a page in the pool's units.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "cluster_residency.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kUnit = kPoolUnitBytes;
static_assert(kUnit % sizeof(sio::GpuClusterVertex) == 0 && kUnit % 3 == 0 && kUnit % 4 == 0 &&
              kUnit % sizeof(sio::GpuCluster) == 0);
// The largest cluster's vertex ids and indices with their alignment: what a unit's tail may lose.
constexpr uint32_t kMaxClusterItem = 4 * MIRAGE_CLUSTER_MAX_VERTICES + 3 * MIRAGE_CLUSTER_MAX_TRIANGLES + 6;

uint32_t alignUp(uint32_t v, uint32_t a) { return (v + a - 1) / a * a; }

// The DAG group tree's owner of each group (LodTreeMesh::groupOwner) from the table alone, which
// does not say which group made a cluster (its page does): a group's outputs are members of groups
// in its own page or in the pages it depends on (buildPages: a page depends on the pages of its
// groups' outputs), or roots there. Of those groups, of a higher level and no smaller error, the
// smallest whose sphere holds the group's (the whole DAG's owner, the member group of the group's
// first output, is one of them), else the one the group's sphere sticks out of least; the root node
// where there is none.
std::vector<uint32_t> pagedGroupOwners(const lod::PageTable& t) {
  std::vector<uint32_t> owner(t.groupLevel.size(), lod::kNone);
  for (uint32_t g = 0; g < owner.size(); ++g) {
    const lod::LodBounds& b = t.groupBounds[g];
    float bestExcess = std::numeric_limits<float>::infinity(), bestRadius = bestExcess;
    auto consider = [&](uint32_t page) {
      for (uint32_t h : t.groupsOf(page)) {
        const lod::LodBounds& o = t.groupBounds[h];
        if (t.groupLevel[h] <= t.groupLevel[g] || o.error < b.error) continue;
        float excess = std::max(0.0f, glm::length(o.center - b.center) + b.radius - o.radius);
        if (excess < bestExcess || (excess == bestExcess && o.radius < bestRadius))
          owner[g] = h, bestExcess = excess, bestRadius = o.radius;
      }
    };
    consider(t.groupPage[g]);
    for (uint32_t d : t.dependenciesOf(t.groupPage[g])) consider(d);
  }
  return owner;
}

} // namespace

uint32_t poolUnitsBound(uint32_t vertices, uint32_t vertexIds, uint32_t triangles, uint32_t clusters) {
  // Every unit but the last is filled to within one cluster item (vertices and records fill theirs
  // whole); the records start on a record boundary.
  uint64_t content = uint64_t(vertices) * sizeof(sio::GpuClusterVertex) + uint64_t(vertexIds) * 4 +
                     uint64_t(triangles) * 3 + uint64_t(clusters) * 6 +
                     uint64_t(clusters + 1) * sizeof(sio::GpuCluster);
  return uint32_t(content / (kUnit - kMaxClusterItem) + 1);
}

uint32_t layoutPage(const lod::PageData& page, const uint32_t* units, PagePacking* out) {
  uint32_t k = 0, off = 0;
  std::vector<uint32_t> vertexId; // page vertex -> pool vertex
  auto at = [&](uint32_t unit, uint32_t o) { return out->bytes.data() + size_t(unit) * kUnit + o; };
  auto fill = [&](uint32_t unit, uint32_t end) {
    if (out->unitFill.size() <= unit) out->unitFill.resize(unit + 1, 0);
    out->unitFill[unit] = std::max(out->unitFill[unit], end);
  };
  if (out) {
    out->bytes.assign(size_t(layoutPage(page, nullptr, nullptr)) * kUnit, 0);
    out->unitFill.clear();
    out->vertexOffset.clear();
    out->triangleOffset.clear();
    out->recordOffset.clear();
    vertexId.resize(page.positions.size());
    out->geometryBytes = page.positions.size() * sizeof(sio::GpuClusterVertex) + page.clusterVertices.size() * 4 +
                         page.clusterIndices.size();
  }
  // Vertices first, in page order, filling units whole.
  for (size_t v = 0; v < page.positions.size(); ++v) {
    if (off + sizeof(sio::GpuClusterVertex) > kUnit) ++k, off = 0;
    if (out) {
      sio::GpuClusterVertex g{};
      g.position = page.positions[v];
      g.normal = v < page.normals.size() ? page.normals[v] : glm::vec3(0, 1, 0);
      g.uv = v < page.uv0.size() ? page.uv0[v] : glm::vec2(0.0f);
      std::memcpy(at(k, off), &g, sizeof(g));
      vertexId[v] = uint32_t((uint64_t(units[k]) * kUnit + off) / sizeof(g));
      fill(k, off + uint32_t(sizeof(g)));
    }
    off += uint32_t(sizeof(sio::GpuClusterVertex));
  }
  // Then per cluster its vertex ids (4-byte aligned) and indices (on a triangle boundary), whole in one unit.
  for (const lod::Cluster& c : page.clusters) {
    uint32_t ids = alignUp(off, 4), tris = alignUp(ids + 4u * c.vertexCount, 3);
    if (tris + 3u * c.triangleCount > kUnit) {
      ++k;
      ids = 0, tris = alignUp(4u * c.vertexCount, 3);
    }
    off = tris + 3u * c.triangleCount;
    if (!out) continue;
    uint64_t base = uint64_t(units[k]) * kUnit;
    for (uint32_t j = 0; j < c.vertexCount; ++j) {
      uint32_t id = vertexId[page.clusterVertices[c.vertexOffset + j]];
      std::memcpy(at(k, ids + 4 * j), &id, 4);
    }
    std::memcpy(at(k, tris), page.clusterIndices.data() + size_t(c.triangleOffset) * 3, size_t(c.triangleCount) * 3);
    out->vertexOffset.push_back(uint32_t((base + ids) / 4));
    out->triangleOffset.push_back(uint32_t((base + tris) / 3));
    fill(k, off);
  }
  // Then the records, on record boundaries (a unit holds whole records), in the tail and units of
  // their own; their bytes are staged apart (they hold pool offsets), so units' fills leave them out.
  constexpr uint32_t kRecord = sizeof(sio::GpuCluster);
  for (size_t i = 0; i < page.clusters.size(); ++i) {
    off = alignUp(off, kRecord);
    if (off + kRecord > kUnit) ++k, off = 0;
    if (out) out->recordOffset.push_back(uint32_t(k) * kUnit + off);
    off += kRecord;
  }
  return k + 1;
}

namespace {

// One paged mesh's trees (LodTreeMesh from the table; its records and levels the last of `out`'s).
// The root pages (here) give their clusters' self and culling spheres; the other clusters' arrive
// with their pages, and the bounds above them grow then (growTrees).
Status appendPagedTrees(const lod::PagedLodAsset& asset, uint32_t m, std::span<const uint32_t> memberGroup,
                        std::span<const uint32_t> memberOffset, std::span<const uint32_t> groupMembers,
                        sio::GpuClusterMesh& gm, PagedSceneTables& out, const std::string& file) {
  const lod::PageTable& t = asset.meshes[m].table;
  std::vector<uint8_t> spheresKnown(gm.clusterCount, 0);
  for (const lod::PageData& page : asset.rootPages[m])
    for (size_t i = 0; i < page.clusters.size(); ++i) {
      sio::GpuCluster full = clusterRecord(page.clusters[i], m);
      sio::GpuCluster& rec = out.clusters[gm.clusterOffset + page.clusterIds[i]];
      rec.selfSphere = full.selfSphere;
      rec.boundsSphere = full.boundsSphere;
      spheresKnown[page.clusterIds[i]] = 1;
    }
  std::vector<uint32_t> roots;
  for (uint32_t c = 0; c < gm.clusterCount; ++c)
    if (memberGroup[c] == lod::kNone) roots.push_back(c);
  std::vector<uint32_t> owners = pagedGroupOwners(t);
  LodTreeMesh tree;
  tree.clusters = std::span(out.clusters).subspan(gm.clusterOffset, gm.clusterCount);
  tree.spheresKnown = spheresKnown;
  tree.memberGroup = memberGroup;
  tree.levels = std::span(out.levels).subspan(gm.levelOffset, gm.levelCount);
  tree.groupLevel = t.groupLevel;
  tree.memberOffset = memberOffset;
  tree.groupMembers = groupMembers;
  tree.groupOwner = owners;
  tree.roots = roots;
  return appendLodTrees(tree, gm, out.trees, fmt::format("{}: mesh {}", file, m));
}

} // namespace

Result<PagedSceneTables> pagedSceneTables(const lod::PagedLodAsset& asset) {
  const Scene& scene = asset.scene;
  const std::string& file = asset.reader ? asset.reader->path() : scene.source;
  PagedSceneTables out;
  out.trees.growable = true;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (uint32_t m = 0; m < asset.meshes.size(); ++m) {
    const lod::PageTable& t = asset.meshes[m].table;
    const lod::PagedDagRest& rest = asset.meshes[m].rest;
    uint32_t count = uint32_t(t.clusterPage.size()), base = uint32_t(out.clusters.size());
    // Per group its members, per cluster its member group (kNone for roots), from the pages' group
    // lists (a page lists its groups' members group after group).
    std::vector<uint32_t> memberOffset(t.groupLevel.size() + 1, 0), groupMembers(count);
    std::vector<uint32_t> memberGroup(count, lod::kNone);
    for (uint32_t g = 0; g < t.groupLevel.size(); ++g) memberOffset[g + 1] = memberOffset[g] + t.groupClusterCount[g];
    for (uint32_t p = 0; p < t.pages.size(); ++p) {
      std::span<const uint32_t> ids = t.clustersOf(p);
      uint32_t at = 0;
      for (uint32_t g : t.groupsOf(p))
        for (uint32_t i = 0; i < t.groupClusterCount[g]; ++i, ++at) {
          memberGroup[ids[at]] = g;
          groupMembers[memberOffset[g] + i] = ids[at];
        }
    }
    // Levels: clusters come ordered by level, the level statistics count them.
    sio::GpuClusterMesh gm{};
    gm.clusterOffset = base;
    gm.clusterCount = count;
    gm.material = scene.meshes[m].material;
    gm.levelOffset = uint32_t(out.levels.size());
    uint32_t first = 0;
    for (uint32_t l = 0; l < rest.levels.size(); ++l) {
      uint32_t n = rest.levels[l].clusters;
      if (n == 0) continue;
      if (uint64_t(first) + n > count)
        return Error{fmt::format("{}: mesh {}: level statistics count more clusters than the page table", file, m)};
      sio::GpuClusterLevel level{first, n, kInf, 0.0f};
      for (uint32_t c = first; c < first + n; ++c) {
        uint32_t g = memberGroup[c];
        level.maxParentError = std::max(level.maxParentError, g == lod::kNone ? kInf : t.groupBounds[g].error);
        sio::GpuCluster rec{};
        rec.parentSphere =
            g == lod::kNone ? glm::vec4(0.0f) : glm::vec4(t.groupBounds[g].center, t.groupBounds[g].radius);
        rec.parentError = g == lod::kNone ? kInf : t.groupBounds[g].error;
        rec.mesh = m;
        rec.level = l;
        rec.maxEdge = kInf; // measured when its page loads (cluster_residency.cpp)
        out.clusters.push_back(rec);
      }
      // Self errors: level 0's are 0, level l's those of the groups of level l - 1 (which made them).
      if (l == 0) level.minSelfError = 0.0f;
      for (uint32_t g = 0; g < t.groupLevel.size() && l > 0; ++g)
        if (t.groupLevel[g] + 1 == l) level.minSelfError = std::min(level.minSelfError, t.groupBounds[g].error);
      if (std::isinf(level.minSelfError)) level.minSelfError = 0.0f;
      out.levels.push_back(level);
      first += n;
    }
    if (first != count)
      return Error{
          fmt::format("{}: mesh {}: level statistics count {} clusters, the page table {}", file, m, first, count)};
    gm.levelCount = uint32_t(out.levels.size()) - gm.levelOffset;
    if (Status st = appendPagedTrees(asset, m, memberGroup, memberOffset, groupMembers, gm, out, file); !st)
      return st.error();
    // Sphere from the positions' box (the whole DAG's), reach over every LOD sphere: the groups'
    // (parents of their members, selves of what they made, enclosing level 0's own spheres) and
    // the root clusters' (root pages).
    const Bounds& box = rest.positionBounds;
    gm.sphere = glm::vec4(box.empty() ? glm::vec3(0.0f) : box.center(), box.radius());
    glm::vec3 centre(gm.sphere);
    for (const lod::LodBounds& b : t.groupBounds)
      gm.reach = std::max(gm.reach, glm::length(b.center - centre) + b.radius);
    for (const lod::PageData& page : asset.rootPages[m])
      for (const lod::Cluster& c : page.clusters)
        for (const lod::LodBounds* b : {&c.self, &c.parent, &c.bounds})
          gm.reach = std::max(gm.reach, glm::length(b->center - centre) + b->radius);
    out.maxMeshClusters = std::max(out.maxMeshClusters, count);
    out.meshes.push_back(gm);
    out.meshBounds.push_back(box);
  }
  if (out.clusters.empty()) return Error{file + ": the asset has no clusters"};
  return out;
}

Result<PagedClusterScene> uploadPagedClusterScene(Context& ctx, const lod::PagedLodAsset& asset) {
  auto tables = pagedSceneTables(asset);
  if (!tables) return tables.error();
  PagedClusterScene out;
  ClusterSceneData& d = out.scene;
  if (Status st = uploadClusterInstances(ctx, asset.scene, tables->meshes, tables->meshBounds, d); !st)
    return st.error();
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  constexpr VkBufferUsageFlags kCopied = kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  // No cluster records here: they arrive with their pages into the pool (createClusterResidency).
  d.levels = createBufferWithData<sio::GpuClusterLevel>(ctx, tables->levels, kStorage, "cluster levels");
  uploadLodTrees(ctx, tables->trees, kCopied, d); // grown as pages arrive
  d.clusterCount = uint32_t(tables->clusters.size());
  d.maxMeshClusters = tables->maxMeshClusters;
  out.trees = std::move(tables->trees);
  out.trees.leafClusters = {}; // on the GPU; growing needs the nodes alone
  return out;
}

} // namespace mirage::render
