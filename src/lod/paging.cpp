// Page layout, dependencies and the residency-aware cut (docs/lod.md, "Paging").
#include "mirage/lod/paging.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "mirage/shaderio/lod_error.h"
#include "mirage/shaderio/lod_paging.h"
#include "morton.h"
#include "page_codec.h"

namespace mirage::lod {

static_assert(MIRAGE_PAGE_NONE == kNone, "one id for 'no page' on both sides");

namespace {

// 30-bit Morton code of a point in `box` (10 bits per axis).
uint32_t mortonCode(const Bounds& box, glm::vec3 p) {
  glm::vec3 extent = glm::max(box.max - box.min, glm::vec3(1e-30f));
  glm::vec3 t = glm::clamp((p - box.min) / extent, 0.0f, 1.0f) * 1023.0f;
  return detail::spreadBits(uint32_t(t.x)) | detail::spreadBits(uint32_t(t.y)) << 1 |
         detail::spreadBits(uint32_t(t.z)) << 2;
}

// The clusters of one packing unit: a root cluster, or a group's member clusters.
struct Unit {
  uint32_t group = kNone; // kNone: a root cluster
  uint32_t cluster = kNone;
};

void appendClusters(const ClusterDag& dag, const Unit& u, std::vector<uint32_t>& out) {
  if (u.group == kNone) {
    out.push_back(u.cluster);
    return;
  }
  const Group& g = dag.groups[u.group];
  out.insert(out.end(), dag.groupChildren.begin() + g.childOffset,
             dag.groupChildren.begin() + g.childOffset + g.childCount);
}

// Packs `units` (in order) into pages of at most `budget` encoded bytes: as many consecutive units
// as fit, a unit larger than the budget alone. Sizes are first estimated from each unit's own
// encoding (an upper bound in practice: one page's header instead of several, shared vertices
// once), then the page is encoded and grown or shrunk by exact sizes.
void packUnits(detail::PageEncodeContext& ctx, const std::vector<Unit>& units, uint32_t budget, PagedDag& out) {
  const ClusterDag& dag = *ctx.dag;
  std::vector<size_t> unitBytes(units.size());
  std::vector<uint32_t> clusters;
  for (size_t i = 0; i < units.size(); ++i) {
    clusters.clear();
    appendClusters(dag, units[i], clusters);
    unitBytes[i] = detail::encodePage(ctx, 0, clusters).bytes.size();
  }
  uint32_t page = uint32_t(out.pages.size());
  auto encodeRange = [&](size_t begin, size_t end) {
    clusters.clear();
    for (size_t i = begin; i < end; ++i) appendClusters(dag, units[i], clusters);
    return detail::encodePage(ctx, page, clusters);
  };
  for (size_t begin = 0; begin < units.size();) {
    size_t end = begin + 1, estimate = unitBytes[begin];
    while (end < units.size() && estimate + unitBytes[end] <= budget) estimate += unitBytes[end++];
    detail::EncodedPage encoded = encodeRange(begin, end);
    while (encoded.bytes.size() > budget && end > begin + 1) encoded = encodeRange(begin, --end);
    while (end < units.size()) {
      detail::EncodedPage more = encodeRange(begin, end + 1);
      if (more.bytes.size() > budget) break;
      encoded = std::move(more);
      ++end;
    }
    PageInfo info;
    info.clusterOffset = uint32_t(out.table.pageClusters.size());
    info.groupOffset = uint32_t(out.table.pageGroups.size());
    for (size_t i = begin; i < end; ++i) {
      appendClusters(dag, units[i], out.table.pageClusters);
      if (units[i].group != kNone) out.table.pageGroups.push_back(units[i].group);
    }
    info.clusterCount = uint32_t(out.table.pageClusters.size()) - info.clusterOffset;
    info.groupCount = uint32_t(out.table.pageGroups.size()) - info.groupOffset;
    info.vertexCount = encoded.vertexCount;
    info.triangleCount = encoded.triangleCount;
    info.bytes = uint32_t(encoded.bytes.size());
    out.table.pages.push_back(info);
    out.pages.push_back(std::move(encoded.bytes));
    ++page;
    begin = end;
  }
}

} // namespace

PagedDag buildPages(const ClusterDag& dag, const PageConfig& config) {
  detail::PageEncodeContext ctx = detail::makePageEncodeContext(dag, config.positionBits);
  PagedDag out;
  PageTable& t = out.table;
  t.positionBits = ctx.grid.bits, t.gridOrigin = ctx.grid.origin, t.gridStep = ctx.grid.step;
  t.hasNormals = !dag.normals.empty(), t.hasUv = !dag.uv0.empty();
  t.groupLevel.resize(dag.groups.size());
  for (size_t g = 0; g < dag.groups.size(); ++g) t.groupLevel[g] = dag.groups[g].level;
  t.groupBounds = ctx.groupBounds;
  t.groupClusterCount.resize(dag.groups.size());
  for (size_t g = 0; g < dag.groups.size(); ++g) t.groupClusterCount[g] = dag.groups[g].childCount;

  Bounds box;
  for (glm::vec3 p : dag.positions) box.add(p);
  // Roots in Morton order of their culling spheres; groups coarse to fine, Morton order of their
  // spheres within a level (neighbouring groups of a level share pages and border vertices).
  std::vector<std::pair<uint64_t, Unit>> order;
  for (uint32_t c : dag.roots) order.push_back({mortonCode(box, dag.clusters[c].bounds.center), Unit{kNone, c}});
  std::vector<Unit> roots, groups;
  std::stable_sort(order.begin(), order.end(), [](auto& a, auto& b) { return a.first < b.first; });
  for (auto& [key, u] : order) roots.push_back(u);
  order.clear();
  uint32_t maxLevel = 0;
  for (const Group& g : dag.groups) maxLevel = std::max(maxLevel, g.level);
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    uint64_t key = uint64_t(maxLevel - dag.groups[g].level) << 32 | mortonCode(box, dag.groups[g].bounds.center);
    order.push_back({key, Unit{g, kNone}});
  }
  std::stable_sort(order.begin(), order.end(), [](auto& a, auto& b) { return a.first < b.first; });
  for (auto& [key, u] : order) groups.push_back(u);

  packUnits(ctx, roots, config.pageBytes, out);
  t.rootPageCount = uint32_t(t.pages.size());
  packUnits(ctx, groups, config.pageBytes, out);

  t.groupPage.assign(dag.groups.size(), kNone);
  t.clusterPage.assign(dag.clusters.size(), kNone);
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    for (uint32_t g : t.groupsOf(p)) t.groupPage[g] = p;
    for (uint32_t c : t.clustersOf(p)) t.clusterPage[c] = p;
  }
  // A page needs the pages holding the parents of its groups: expanding group g (drawing its
  // children instead of its parents) is only crack-free while the parents' own member groups
  // are expanded too, which the rule can only do with their pages resident.
  std::vector<uint32_t> deps;
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    deps.clear();
    for (uint32_t g : t.groupsOf(p)) {
      const Group& gr = dag.groups[g];
      for (uint32_t i = 0; i < gr.parentCount; ++i) {
        uint32_t q = t.clusterPage[dag.groupParents[gr.parentOffset + i]];
        if (q != p) deps.push_back(q);
      }
    }
    std::sort(deps.begin(), deps.end());
    deps.erase(std::unique(deps.begin(), deps.end()), deps.end());
    assert(deps.empty() || deps.back() < p); // parents' groups are of higher levels: earlier pages
    t.pages[p].dependencyOffset = uint32_t(t.dependencies.size());
    t.pages[p].dependencyCount = uint32_t(deps.size());
    t.dependencies.insert(t.dependencies.end(), deps.begin(), deps.end());
  }
  return out;
}

float projectedError(const LodBounds& b, const CutView& view) {
  if (view.pixelScale <= 0.0f) return b.error;
  return shaderio::projectedSphereError(b.center, b.radius, b.error, 1.0f, view.eye, view.znear, view.pixelScale);
}

std::vector<uint32_t> selectCut(const ClusterDag& dag, const CutView& view) {
  std::vector<uint32_t> cut;
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    const Cluster& cl = dag.clusters[c];
    if (projectedError(cl.self, view) <= view.tau && projectedError(cl.parent, view) > view.tau) cut.push_back(c);
  }
  return cut;
}

bool residencyClosed(const PageTable& table, std::span<const uint8_t> resident) {
  if (resident.size() != table.pages.size()) return false;
  for (uint32_t p = 0; p < table.pages.size(); ++p) {
    if (p < table.rootPageCount && !resident[p]) return false;
    if (resident[p])
      for (uint32_t d : table.dependenciesOf(p))
        if (!resident[d]) return false;
  }
  return true;
}

namespace {

std::vector<PageRequest> sortedRequests(const std::vector<float>& priority) {
  std::vector<PageRequest> out;
  for (uint32_t p = 0; p < priority.size(); ++p)
    if (priority[p] > 0.0f) out.push_back({p, priority[p]});
  std::stable_sort(out.begin(), out.end(),
                   [](const PageRequest& a, const PageRequest& b) { return a.priority > b.priority; });
  return out;
}

} // namespace

ResidentCut selectResidentCut(const ClusterDag& dag, const PageTable& table, std::span<const uint8_t> resident,
                              const CutView& view) {
  assert(residencyClosed(table, resident));
  ResidentCut out;
  std::vector<float> priority(table.pages.size(), 0.0f);
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    if (!resident[table.clusterPage[c]]) continue;
    const Cluster& cl = dag.clusters[c];
    uint32_t childPage = table.childPage(cl.generatingGroup);
    // Level 0: error 0; roots: +inf (as the decoders derive a cluster's own and parent bounds).
    float self = cl.generatingGroup == kNone ? 0.0f : projectedError(table.groupBounds[cl.generatingGroup], view);
    float parent =
        cl.group == kNone ? std::numeric_limits<float>::infinity() : projectedError(table.groupBounds[cl.group], view);
    bool selfWithin = self <= view.tau;
    bool parentAbove = parent > view.tau;
    bool childrenResident = childPage != kNone && resident[childPage];
    if (shaderio::residentCutDraws(selfWithin, parentAbove, childrenResident)) out.clusters.push_back(c);
    if (childPage != kNone && shaderio::residentCutRequests(selfWithin, parentAbove, childrenResident))
      priority[childPage] = std::max(priority[childPage], shaderio::pageRequestPriority(self, view.tau));
  }
  out.requests = sortedRequests(priority);
  return out;
}

std::vector<PageRequest> wantedPages(const PageTable& table, std::span<const uint8_t> resident, const CutView& view) {
  std::vector<float> priority(table.pages.size(), 0.0f);
  for (uint32_t g = 0; g < table.groupBounds.size(); ++g) {
    float e = projectedError(table.groupBounds[g], view);
    if (e > view.tau) {
      float& p = priority[table.groupPage[g]];
      p = std::max(p, shaderio::pageRequestPriority(e, view.tau));
    }
  }
  // Dependencies have lower indices: one pass from the finest page raises each to its dependents'.
  for (uint32_t p = uint32_t(table.pages.size()); p-- > 0;)
    if (priority[p] > 0.0f)
      for (uint32_t d : table.dependenciesOf(p)) priority[d] = std::max(priority[d], priority[p]);
  for (uint32_t p = 0; p < priority.size(); ++p)
    if (resident[p]) priority[p] = 0.0f;
  return sortedRequests(priority);
}

} // namespace mirage::lod
