// Page and page-table encoding (docs/lod.md, "Paging"). A page is standalone: the grid, the LOD
// bounds of every group its clusters refer to, the clusters, their page-local vertices (meshopt
// vertex codec) and indices. Bounds are written as decoded (widened by the grid's slack), so a
// group's bounds are the same floats in the table, in every page and in the CDAG decoder's DAG.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "mirage/asset/bytes.h"
#include "mirage/core/octahedral.h"
#include "mirage/lod/paging.h"
#include "page_codec.h"

namespace mirage::lod {

using asset::ByteReader;
using asset::ByteWriter;
using detail::PackedAttributes;
using detail::PackedPosition;
using detail::PositionGrid;

namespace {

// Larger than any cluster the builder makes; the CDAG decoder takes the same limits.
constexpr uint64_t kMaxClusterVertexCount = 255;
constexpr uint64_t kMaxClusterTriangleCount = 512;
constexpr uint64_t kMaxLevel = 64;

std::string str(uint64_t v) { return std::to_string(v); }

uint8_t attributeFlags(bool normals, bool uv) { return uint8_t((normals ? 1 : 0) | (uv ? 2 : 0)); }

PositionGrid tableGrid(const PageTable& t) {
  PositionGrid g;
  g.bits = t.positionBits;
  g.origin = t.gridOrigin;
  g.step = t.gridStep;
  return g;
}

void writeBounds(ByteWriter& w, const LodBounds& b) {
  detail::writeSphere(w, b);
  w.write(b.error);
}
bool readBounds(ByteReader& r, LodBounds& b) { return detail::readSphere(r, b) && r.read(b.error); }

bool sameBounds(const LodBounds& a, const LodBounds& b) { return std::memcmp(&a, &b, sizeof(LodBounds)) == 0; }

bool finiteSphere(const LodBounds& b) {
  return std::isfinite(b.center.x) && std::isfinite(b.center.y) && std::isfinite(b.center.z) &&
         std::isfinite(b.radius) && b.radius >= 0.0f;
}

} // namespace

namespace detail {

PageEncodeContext makePageEncodeContext(const ClusterDag& dag, uint32_t positionBits) {
  PageEncodeContext ctx;
  ctx.dag = &dag;
  ctx.grid = choosePositionGrid(dag.positions, positionBits, ctx.packed);
  float slack = positionSlack(ctx.grid);
  ctx.groupBounds.resize(dag.groups.size());
  for (size_t g = 0; g < dag.groups.size(); ++g)
    ctx.groupBounds[g] = widenGroupBounds(dag.groups[g].bounds, dag.groups[g].level, slack);
  ctx.clusterRadius.resize(dag.clusters.size());
  for (size_t c = 0; c < dag.clusters.size(); ++c)
    ctx.clusterRadius[c] = widenClusterRadius(dag.clusters[c].bounds.radius, slack);
  ctx.localId.assign(dag.vertexPosition.size(), kNone);
  return ctx;
}

EncodedPage encodePage(PageEncodeContext& ctx, uint32_t page, std::span<const uint32_t> clusters) {
  const ClusterDag& dag = *ctx.dag;
  EncodedPage out;
  ByteWriter w;
  w.write(kPageCodecVersion);
  w.writeVarint(page);
  writeGrid(w, ctx.grid);
  uint8_t flags = attributeFlags(!dag.normals.empty(), !dag.uv0.empty());
  w.write(flags);

  // Every group the clusters refer to (member and generating), each once, ascending.
  std::vector<uint32_t> groups;
  for (uint32_t c : clusters)
    for (uint32_t g : {dag.clusters[c].group, dag.clusters[c].generatingGroup})
      if (g != kNone) groups.push_back(g);
  std::sort(groups.begin(), groups.end());
  groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
  writeIds(w, groups);
  for (uint32_t g : groups) {
    w.writeVarint(dag.groups[g].level);
    writeBounds(w, ctx.groupBounds[g]);
  }

  // Clusters, and their vertices numbered by first use.
  writeIds(w, clusters);
  std::vector<uint32_t> vertices, clusterVertices;
  for (uint32_t c : clusters) {
    const Cluster& cl = dag.clusters[c];
    w.writeVarint(cl.vertexCount);
    w.writeVarint(cl.triangleCount);
    w.writeVarint(cl.level);
    w.writeVarint(uint32_t(cl.generatingGroup + 1)); // kNone + 1 wraps to 0
    w.writeVarint(uint32_t(cl.group + 1));
    LodBounds b = cl.bounds;
    b.radius = ctx.clusterRadius[c];
    writeSphere(w, b);
    for (uint32_t i = 0; i < cl.vertexCount; ++i) {
      uint32_t v = dag.clusterVertices[cl.vertexOffset + i];
      if (ctx.localId[v] == kNone) {
        ctx.localId[v] = uint32_t(vertices.size());
        vertices.push_back(v);
      }
      clusterVertices.push_back(ctx.localId[v]);
    }
    out.triangleCount += cl.triangleCount;
  }
  for (uint32_t v : vertices) ctx.localId[v] = kNone;
  out.vertexCount = uint32_t(vertices.size());

  w.writeVarint(vertices.size());
  std::vector<PackedPosition> positions(vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) positions[i] = ctx.packed[dag.vertexPosition[vertices[i]]];
  writeVertexStream(w, positions.data(), positions.size(), sizeof(PackedPosition));
  if (flags) {
    std::vector<PackedAttributes> attrs(vertices.size());
    for (size_t i = 0; i < vertices.size(); ++i) {
      uint32_t v = vertices[i];
      uint32_t n = dag.normals.empty() ? 0u : encodeOctahedral(dag.normals[v]);
      attrs[i] = {n, dag.uv0.empty() ? 0.0f : dag.uv0[v].x, dag.uv0.empty() ? 0.0f : dag.uv0[v].y};
    }
    writeVertexStream(w, attrs.data(), attrs.size(), sizeof(PackedAttributes));
  }
  writeIds(w, clusterVertices);
  std::vector<uint8_t> indices;
  for (uint32_t c : clusters) {
    const Cluster& cl = dag.clusters[c];
    const uint8_t* first = dag.clusterIndices.data() + size_t(cl.triangleOffset) * 3;
    indices.insert(indices.end(), first, first + size_t(cl.triangleCount) * 3);
  }
  w.writeArray(std::span<const uint8_t>(indices));
  out.bytes = w.take();
  return out;
}

} // namespace detail

Result<PageData> decodePage(std::span<const uint8_t> bytes, const PageTable& table, uint32_t page,
                            const std::string& file) {
  std::string where = file + ": page " + str(page);
  if (page >= table.pages.size()) return makeError(where, "not in the page table");
  const PageInfo& info = table.pages[page];
  ByteReader r(bytes, where);
  auto fail = [&](const std::string& what) { return makeError(where, what); };
  uint32_t version = 0;
  if (!r.read(version)) return r.error();
  if (version != kPageCodecVersion)
    return fail("page encoding version " + str(version) + " (this build reads " + str(kPageCodecVersion) + ")");
  uint64_t number = 0;
  PositionGrid grid;
  uint8_t flags = 0;
  if (!r.readVarint(number) || !detail::readGrid(r, grid) || !r.read(flags)) return r.error();
  if (number != page) return fail("holds page " + str(number));
  PositionGrid expected = tableGrid(table);
  if (grid.bits != expected.bits || std::memcmp(&grid.origin, &expected.origin, sizeof(glm::vec3)) != 0 ||
      std::memcmp(&grid.step, &expected.step, sizeof(float)) != 0 || !detail::gridValid(grid))
    return fail("position grid differs from the page table's");
  if (flags != attributeFlags(table.hasNormals, table.hasUv))
    return fail("attribute flags differ from the page table's");

  // Group records: ascending ids of the table, each with the table's level and bounds.
  std::vector<uint32_t> groups;
  if (!detail::readIds(r, groups, table.groupLevel.size(), "group")) return r.error();
  std::vector<LodBounds> groupBounds(groups.size());
  std::vector<uint32_t> groupLevels(groups.size());
  for (size_t i = 0; i < groups.size(); ++i) {
    uint64_t level = 0;
    if (!r.readCount(level, kMaxLevel, "group level") || !readBounds(r, groupBounds[i])) return r.error();
    uint32_t g = groups[i];
    if (g >= table.groupLevel.size() || (i > 0 && g <= groups[i - 1])) return fail("bad group list");
    if (level != table.groupLevel[g] || !sameBounds(groupBounds[i], table.groupBounds[g]))
      return fail("group " + str(g) + " differs from the page table");
    groupLevels[i] = uint32_t(level);
  }
  auto record = [&](uint32_t g) -> int64_t {
    auto it = std::lower_bound(groups.begin(), groups.end(), g);
    return it != groups.end() && *it == g ? int64_t(it - groups.begin()) : -1;
  };

  PageData out;
  out.page = page;
  if (!detail::readIds(r, out.clusterIds, info.clusterCount, "cluster")) return r.error();
  std::span<const uint32_t> expectedClusters = table.clustersOf(page);
  if (!std::equal(out.clusterIds.begin(), out.clusterIds.end(), expectedClusters.begin(), expectedClusters.end()))
    return fail("clusters differ from the page table");
  out.clusters.resize(out.clusterIds.size());
  // Member group of each cluster by the table: the page's groups' members, group after group.
  std::vector<uint32_t> memberGroup(out.clusters.size(), kNone);
  size_t next = 0;
  for (uint32_t g : table.groupsOf(page))
    for (uint32_t k = 0; k < table.groupClusterCount[g] && next < memberGroup.size(); ++k) memberGroup[next++] = g;
  uint64_t vertexTotal = 0, triangleTotal = 0;
  for (size_t i = 0; i < out.clusters.size(); ++i) {
    Cluster& c = out.clusters[i];
    std::string name = "cluster " + str(out.clusterIds[i]);
    uint64_t vc = 0, tc = 0, level = 0, gg = 0, g = 0;
    if (!r.readCount(vc, kMaxClusterVertexCount, "cluster vertex count") ||
        !r.readCount(tc, kMaxClusterTriangleCount, "cluster triangle count") ||
        !r.readCount(level, kMaxLevel, "cluster level") || !r.readCount(gg, UINT32_MAX, "generating group") ||
        !r.readCount(g, UINT32_MAX, "group") || !detail::readSphere(r, c.bounds))
      return r.error();
    if (vc == 0 || tc == 0) return fail(name + " is empty");
    if (!finiteSphere(c.bounds)) return fail(name + " has a bad sphere");
    c.vertexOffset = uint32_t(vertexTotal);
    c.triangleOffset = uint32_t(triangleTotal);
    c.vertexCount = uint16_t(vc);
    c.triangleCount = uint16_t(tc);
    c.level = uint32_t(level);
    c.generatingGroup = uint32_t(gg - 1);
    c.group = uint32_t(g - 1);
    vertexTotal += vc;
    triangleTotal += tc;
    // Own bounds: the generating group's (level 0: the culling sphere, error 0); parent: the member
    // group's (roots: +inf), as decodeDag derives them.
    if (c.generatingGroup == kNone) {
      if (c.level != 0) return fail(name + " above level 0 has no generating group");
      c.self = c.bounds;
      c.self.error = 0.0f;
    } else {
      int64_t k = record(c.generatingGroup);
      if (k < 0) return fail(name + " refers to a group the page does not describe");
      if (c.level != groupLevels[size_t(k)] + 1) return fail(name + " is not one level above its generating group");
      c.self = groupBounds[size_t(k)];
    }
    if (c.group != memberGroup[i]) return fail(name + " is not a member of the group the page table says");
    if (c.group == kNone) {
      c.parent = c.self;
      c.parent.error = std::numeric_limits<float>::infinity();
    } else {
      int64_t k = record(c.group);
      if (k < 0) return fail(name + " refers to a group the page does not describe");
      if (c.level > groupLevels[size_t(k)]) return fail(name + " is above its group's level");
      c.parent = groupBounds[size_t(k)];
    }
  }
  if (triangleTotal != info.triangleCount) return fail("triangle count differs from the page table");

  uint64_t vertexCount = 0;
  if (!r.readCount(vertexCount, std::min<uint64_t>(info.vertexCount, vertexTotal), "vertex count")) return r.error();
  if (vertexCount != info.vertexCount) return fail("vertex count differs from the page table");
  std::vector<PackedPosition> packed(vertexCount);
  if (!detail::readVertexStream(r, bytes, packed.data(), packed.size(), sizeof(PackedPosition))) return r.error();
  out.positions.resize(vertexCount);
  for (size_t i = 0; i < packed.size(); ++i) {
    if (!detail::packedValid(grid, packed[i]))
      return fail(grid.raw() ? "non-finite position" : "position off the grid");
    out.positions[i] = detail::unpackPosition(grid, packed[i]);
  }
  if (flags) {
    std::vector<PackedAttributes> attrs(vertexCount);
    if (!detail::readVertexStream(r, bytes, attrs.data(), attrs.size(), sizeof(PackedAttributes))) return r.error();
    if (flags & 1) out.normals.resize(vertexCount);
    if (flags & 2) out.uv0.resize(vertexCount);
    for (size_t i = 0; i < attrs.size(); ++i) {
      if (flags & 1) out.normals[i] = decodeOctahedral(attrs[i].normal);
      if (flags & 2) out.uv0[i] = {attrs[i].u, attrs[i].v};
    }
  }
  if (!detail::readIds(r, out.clusterVertices, vertexTotal, "cluster vertex")) return r.error();
  if (out.clusterVertices.size() != vertexTotal) return fail("cluster vertex list size mismatch");
  for (uint32_t v : out.clusterVertices)
    if (v >= vertexCount) return fail("cluster refers to a missing vertex");
  if (!r.readArray(out.clusterIndices)) return r.error();
  if (out.clusterIndices.size() != triangleTotal * 3) return fail("cluster index list size mismatch");
  for (size_t i = 0; i < out.clusters.size(); ++i) {
    const Cluster& c = out.clusters[i];
    const uint8_t* idx = out.clusterIndices.data() + size_t(c.triangleOffset) * 3;
    for (size_t k = 0; k < size_t(c.triangleCount) * 3; ++k)
      if (idx[k] >= c.vertexCount) return fail("cluster " + str(out.clusterIds[i]) + " local index out of range");
  }
  if (Status s = r.finish(); !s) return s.error();
  if (bytes.size() != info.bytes) return fail("size differs from the page table");
  return out;
}

std::vector<uint8_t> encodePageTable(const PageTable& t) {
  ByteWriter w;
  w.write(kPageCodecVersion);
  detail::writeGrid(w, tableGrid(t));
  w.write(attributeFlags(t.hasNormals, t.hasUv));
  w.writeVarint(t.clusterPage.size());
  w.writeVarint(t.groupLevel.size());
  for (size_t g = 0; g < t.groupLevel.size(); ++g) {
    w.writeVarint(t.groupLevel[g]);
    w.writeVarint(t.groupClusterCount[g]);
    writeBounds(w, t.groupBounds[g]);
  }
  w.writeVarint(t.rootPageCount);
  w.writeVarint(t.pages.size());
  for (const PageInfo& p : t.pages) {
    w.writeVarint(p.groupCount), w.writeVarint(p.clusterCount), w.writeVarint(p.dependencyCount);
    w.writeVarint(p.vertexCount), w.writeVarint(p.triangleCount), w.writeVarint(p.bytes);
  }
  detail::writeIds(w, t.pageGroups);
  detail::writeIds(w, t.pageClusters);
  detail::writeIds(w, t.dependencies);
  return w.take();
}

Result<PageTable> decodePageTable(std::span<const uint8_t> bytes, const std::string& file) {
  std::string where = file + ": page table";
  ByteReader r(bytes, where);
  auto fail = [&](const std::string& what) { return makeError(where, what); };
  PageTable t;
  uint32_t version = 0;
  if (!r.read(version)) return r.error();
  if (version != kPageCodecVersion)
    return fail("page encoding version " + str(version) + " (this build reads " + str(kPageCodecVersion) + ")");
  PositionGrid grid;
  uint8_t flags = 0;
  if (!detail::readGrid(r, grid) || !r.read(flags)) return r.error();
  if (!detail::gridValid(grid)) return fail("bad position quantization");
  if (flags > 3) return fail("unknown attribute flags");
  t.positionBits = grid.bits, t.gridOrigin = grid.origin, t.gridStep = grid.step;
  t.hasNormals = flags & 1, t.hasUv = flags & 2;

  // Counts are bounded by the bytes left (each element takes at least one byte), so a corrupt
  // count cannot allocate much.
  uint64_t clusterCount = 0, groupCount = 0, rootPages = 0, pageCount = 0;
  if (!r.readCount(clusterCount, r.remaining(), "cluster count") ||
      !r.readCount(groupCount, r.remaining() / 22, "group count"))
    return r.error();
  t.groupLevel.resize(groupCount);
  t.groupClusterCount.resize(groupCount);
  t.groupBounds.resize(groupCount);
  for (size_t g = 0; g < groupCount; ++g) {
    uint64_t level = 0, members = 0;
    if (!r.readCount(level, kMaxLevel, "group level") || !r.readCount(members, clusterCount, "group cluster count") ||
        !readBounds(r, t.groupBounds[g]))
      return r.error();
    if (members == 0) return fail("group " + str(g) + " has no clusters");
    if (!finiteSphere(t.groupBounds[g]) || !(t.groupBounds[g].error >= 0.0f))
      return fail("group " + str(g) + " has bad bounds");
    t.groupLevel[g] = uint32_t(level);
    t.groupClusterCount[g] = uint32_t(members);
  }
  if (!r.readCount(rootPages, r.remaining(), "root page count") ||
      !r.readCount(pageCount, r.remaining() / 6, "page count"))
    return r.error();
  if (rootPages == 0 || rootPages > pageCount) return fail("bad root page count");
  t.rootPageCount = uint32_t(rootPages);
  t.pages.resize(pageCount);
  uint64_t groups = 0, clusters = 0, deps = 0;
  for (PageInfo& p : t.pages) {
    uint64_t gc = 0, cc = 0, dc = 0, vc = 0, tc = 0, b = 0;
    if (!r.readCount(gc, groupCount, "page group count") || !r.readCount(cc, clusterCount, "page cluster count") ||
        !r.readCount(dc, pageCount, "page dependency count") || !r.readCount(vc, UINT32_MAX, "page vertex count") ||
        !r.readCount(tc, UINT32_MAX, "page triangle count") || !r.readCount(b, UINT32_MAX, "page size"))
      return r.error();
    p.groupOffset = uint32_t(groups), p.groupCount = uint32_t(gc);
    p.clusterOffset = uint32_t(clusters), p.clusterCount = uint32_t(cc);
    p.dependencyOffset = uint32_t(deps), p.dependencyCount = uint32_t(dc);
    p.vertexCount = uint32_t(vc), p.triangleCount = uint32_t(tc), p.bytes = uint32_t(b);
    groups += gc, clusters += cc, deps += dc;
    if (groups > groupCount || clusters > clusterCount || deps > UINT32_MAX) return fail("page ranges overflow");
  }
  if (!detail::readIds(r, t.pageGroups, groups, "page group") ||
      !detail::readIds(r, t.pageClusters, clusters, "page cluster") ||
      !detail::readIds(r, t.dependencies, deps, "page dependency"))
    return r.error();
  if (Status s = r.finish(); !s) return s.error();
  if (t.pageGroups.size() != groupCount || t.pageClusters.size() != clusterCount || t.dependencies.size() != deps)
    return fail("list sizes differ from the pages'");

  // Each group in one page (not a root page), each cluster in one page, pages not empty,
  // dependencies ascending and below their page.
  t.groupPage.assign(groupCount, kNone);
  t.clusterPage.assign(clusterCount, kNone);
  for (uint32_t p = 0; p < t.pages.size(); ++p) {
    const PageInfo& info = t.pages[p];
    std::string name = "page " + str(p);
    if (info.clusterCount == 0 || info.bytes == 0) return fail(name + " is empty");
    if ((p < t.rootPageCount) != (info.groupCount == 0)) return fail(name + " root/group mismatch");
    if (p < t.rootPageCount && info.dependencyCount != 0) return fail(name + " is a root page with dependencies");
    uint64_t members = 0;
    for (uint32_t g : t.groupsOf(p)) {
      if (g >= groupCount || t.groupPage[g] != kNone) return fail(name + " lists group " + str(g) + " badly");
      t.groupPage[g] = p;
      members += t.groupClusterCount[g];
    }
    if (p >= t.rootPageCount && members != info.clusterCount)
      return fail(name + " has other clusters than its groups' members");
    for (uint32_t c : t.clustersOf(p)) {
      if (c >= clusterCount || t.clusterPage[c] != kNone) return fail(name + " lists cluster " + str(c) + " badly");
      t.clusterPage[c] = p;
    }
    uint32_t previous = 0;
    for (uint32_t i = 0; i < info.dependencyCount; ++i) {
      uint32_t d = t.dependencies[info.dependencyOffset + i];
      if (d >= p || (i > 0 && d <= previous)) return fail(name + " has a bad dependency " + str(d));
      previous = d;
    }
  }
  return t;
}

} // namespace mirage::lod
