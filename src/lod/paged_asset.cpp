// The 'CPAG' chunk: a paged cluster DAG stored as a blocked chunk (docs/lod.md, "Paged chunk").
// Index header: u32 version, the page table (varint length + encodePageTable bytes), u64 input
// triangles, per group the simplifier's error (varint count + f32 each), the root list (ids), the
// level statistics, the decoded positions' box (2 x vec3, min > max when empty) and per page its
// vertex-id count (varints). Block p: page p's bytes (decodePage).
#include "mirage/lod/paged_asset.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "codec_common.h"
#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/lod/verify.h"

namespace mirage::lod {

using asset::ByteReader;
using asset::ByteWriter;

namespace {

std::string str(uint64_t v) { return std::to_string(v); }

uint32_t bitsOf(float f) {
  uint32_t u = 0;
  std::memcpy(&u, &f, 4);
  return u;
}

// Ids for distinct keys of a few 32-bit words (exact float bits: every page decodes a vertex to the
// same bits), numbered by first insertion: open addressing over a table of at least twice the
// inserts (std::unordered_map took half of a dragon's load).
template <size_t N> class FirstUseIds {
public:
  using Key = std::array<uint32_t, N>;
  explicit FirstUseIds(size_t maxInserts) {
    size_t n = 16;
    while (n < maxInserts * 2) n *= 2;
    slots_.assign(n, kNone);
  }
  // The key's id, and whether it was new.
  std::pair<uint32_t, bool> insert(const Key& k) {
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (uint32_t w : k) h = (h ^ w) * 0xff51afd7ed558ccdull, h ^= h >> 29;
    for (size_t i = size_t(h) & (slots_.size() - 1);; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i] == kNone) {
        slots_[i] = uint32_t(keys_.size());
        keys_.push_back(k);
        return {slots_[i], true};
      }
      if (keys_[slots_[i]] == k) return {slots_[i], false};
    }
  }

private:
  std::vector<uint32_t> slots_;
  std::vector<Key> keys_;
};

} // namespace

Result<std::vector<uint8_t>> encodePagedChunk(const ClusterDag& dag, const PageConfig& config, int zstdLevel) {
  PagedDag paged = buildPages(dag, config);
  ByteWriter w;
  w.write(kPagedChunkVersion);
  std::vector<uint8_t> table = encodePageTable(paged.table);
  w.writeArray(std::span<const uint8_t>(table));
  w.write(uint64_t(dag.inputTriangles));
  std::vector<float> simplifyError(dag.groups.size());
  for (size_t g = 0; g < dag.groups.size(); ++g) simplifyError[g] = dag.groups[g].simplifyError;
  w.writeArray(std::span<const float>(simplifyError));
  detail::writeIds(w, dag.roots);
  w.writeVarint(dag.levels.size());
  for (const LevelStats& l : dag.levels) {
    w.write(l.clusters), w.write(l.triangles), w.write(l.meanFill), w.write(l.groups), w.write(l.stuckGroups);
    w.write(l.meanEdgeAge), w.write(0.0f); // LevelStats::seconds: timings stay out of the file
  }
  // The box of the positions as every page decodes them (the grid the pages were encoded on).
  detail::PositionGrid grid{paged.table.positionBits, paged.table.gridOrigin, paged.table.gridStep};
  std::vector<uint8_t> used(dag.positions.size(), 0);
  for (uint32_t v : dag.clusterVertices) used[dag.vertexPosition[v]] = 1;
  Bounds box;
  for (size_t i = 0; i < used.size(); ++i)
    if (used[i]) box.add(detail::unpackPosition(grid, detail::packPosition(grid, dag.positions[i])));
  w.write(box.min), w.write(box.max);
  for (uint32_t p = 0; p < paged.table.pages.size(); ++p) {
    uint64_t ids = 0;
    for (uint32_t c : paged.table.clustersOf(p)) ids += dag.clusters[c].vertexCount;
    w.writeVarint(ids);
  }
  std::vector<uint8_t> header = w.take();
  std::vector<std::span<const uint8_t>> blocks(paged.pages.begin(), paged.pages.end());
  return asset::encodeBlocks(header, blocks, zstdLevel);
}

Result<PagedMesh> decodePagedHeader(std::span<const uint8_t> header, const std::string& context) {
  PagedMesh m;
  ByteReader r(header, context);
  uint32_t version = 0;
  if (!r.read(version)) return r.error();
  if (version != kPagedChunkVersion)
    return makeError(context, "paged chunk version " + str(version) + " (this build reads " + str(kPagedChunkVersion) +
                                  "; rebuild with mirage build)");
  std::vector<uint8_t> table;
  if (!r.readArray(table)) return r.error();
  auto decoded = decodePageTable(table, context);
  if (!decoded) return decoded.error();
  m.table = std::move(decoded).value();
  uint64_t inputTriangles = 0;
  if (!r.read(inputTriangles)) return r.error();
  m.rest.inputTriangles = inputTriangles;
  if (!r.readArray(m.rest.groupSimplifyError)) return r.error();
  if (m.rest.groupSimplifyError.size() != m.table.groupLevel.size())
    return makeError(context, str(m.rest.groupSimplifyError.size()) + " group errors for " +
                                  str(m.table.groupLevel.size()) + " groups");
  if (!detail::readIds(r, m.rest.roots, m.table.clusterPage.size(), "root")) return r.error();
  for (uint32_t c : m.rest.roots)
    if (c >= m.table.clusterPage.size() || m.table.clusterPage[c] >= m.table.rootPageCount)
      return makeError(context, "root " + str(c) + " is not in a root page");
  uint64_t levelCount = 0;
  if (!r.readCount(levelCount, 64, "level count")) return r.error();
  m.rest.levels.resize(levelCount);
  for (LevelStats& l : m.rest.levels)
    if (!r.read(l.clusters) || !r.read(l.triangles) || !r.read(l.meanFill) || !r.read(l.groups) ||
        !r.read(l.stuckGroups) || !r.read(l.meanEdgeAge) || !r.read(l.seconds))
      return r.error();
  Bounds& box = m.rest.positionBounds;
  if (!r.read(box.min) || !r.read(box.max)) return r.error();
  auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (!box.empty() && (!finite(box.min) || !finite(box.max) || glm::any(glm::greaterThan(box.min, box.max))))
    return makeError(context, "bad position bounds");
  m.rest.pageClusterVertices.resize(m.table.pages.size());
  for (uint32_t p = 0; p < m.table.pages.size(); ++p) {
    uint64_t ids = 0;
    if (!r.readVarint(ids)) return r.error();
    // A cluster holds at most 255 vertices (8-bit local indices), each used by a triangle.
    if (ids > uint64_t(m.table.pages[p].triangleCount) * 3 || ids < m.table.pages[p].vertexCount)
      return makeError(context, "page " + str(p) + ": " + str(ids) + " vertex ids for " +
                                    str(m.table.pages[p].vertexCount) + " vertices");
    m.rest.pageClusterVertices[p] = uint32_t(ids);
  }
  if (Status s = r.finish(); !s) return s.error();
  return m;
}

Result<std::vector<PagedMesh>> openPagedMeshes(const asset::AssetReader& reader) {
  std::vector<PagedMesh> out;
  for (size_t i = 0; i < reader.chunks().size(); ++i) {
    if (reader.chunks()[i].type != asset::chunk::ClusterPages) continue;
    std::string context = reader.chunkContext(i);
    if (!reader.chunks()[i].blocked) return makeError(context, "paged cluster DAG is not a blocked chunk");
    auto blocks = reader.readBlockTable(i);
    if (!blocks) return blocks.error();
    auto mesh = decodePagedHeader(blocks->header, context);
    if (!mesh) return mesh.error();
    if (blocks->blocks.size() != mesh->table.pages.size())
      return makeError(context, str(blocks->blocks.size()) + " blocks for " + str(mesh->table.pages.size()) + " pages");
    mesh->chunk = i;
    mesh->blocks = std::move(blocks).value();
    out.push_back(std::move(mesh).value());
  }
  return out;
}

Result<PageData> readPage(const asset::AssetReader& reader, const PagedMesh& mesh, uint32_t page) {
  std::string context = reader.chunkContext(mesh.chunk);
  if (page >= mesh.table.pages.size())
    return makeError(context, "page " + str(page) + " out of range (" + str(mesh.table.pages.size()) + " pages)");
  auto bytes = reader.readBlock(mesh.chunk, mesh.blocks, page);
  if (!bytes) return Error{bytes.error().message + " (page " + str(page) + ")"};
  return decodePage(*bytes, mesh.table, page, context);
}

Result<ClusterDag> decodePagedChunk(std::span<const uint8_t> payload, const std::string& context) {
  auto blocks = asset::decodeBlockTable(payload, context);
  if (!blocks) return blocks.error();
  auto mesh = decodePagedHeader(blocks->header, context);
  if (!mesh) return mesh.error();
  if (blocks->blocks.size() != mesh->table.pages.size())
    return makeError(context, str(blocks->blocks.size()) + " blocks for " + str(mesh->table.pages.size()) + " pages");
  std::vector<PageData> pages;
  for (uint32_t p = 0; p < blocks->blocks.size(); ++p) {
    const asset::BlockInfo& b = blocks->blocks[p];
    auto raw = asset::decodeBlock(*blocks, p, payload.subspan(size_t(b.offset), size_t(b.storedBytes)), context);
    if (!raw) return raw.error();
    auto page = decodePage(*raw, mesh->table, p, context);
    if (!page) return page.error();
    pages.push_back(std::move(page).value());
  }
  return reassemblePagedDag(mesh->table, mesh->rest, pages, context);
}

Result<PagedLodAsset> openPagedLodAsset(const std::string& path, const asset::SourceOptions& options) {
  auto reader = asset::AssetReader::open(path, options);
  if (!reader) return reader.error();
  PagedLodAsset a;
  a.reader = std::make_unique<asset::AssetReader>(std::move(reader).value());
  auto sceneBytes = a.reader->readChunk(asset::chunk::Scene);
  if (!sceneBytes) return sceneBytes.error();
  auto scene = asset::decodeScene(*sceneBytes, path);
  if (!scene) return scene.error();
  a.scene = std::move(scene).value();
  if (auto meta = a.reader->find(asset::chunk::Meta)) {
    auto bytes = a.reader->readChunk(*meta);
    if (!bytes) return bytes.error();
    a.metaJson.assign(bytes->begin(), bytes->end());
  }
  auto meshes = openPagedMeshes(*a.reader);
  if (!meshes) return meshes.error();
  a.meshes = std::move(meshes).value();
  if (a.meshes.empty()) return makeError(path, "needs a paged asset (mirage build --paged): no 'CPAG' chunk");
  if (a.meshes.size() != a.scene.meshes.size())
    return makeError(path, str(a.meshes.size()) + " paged cluster DAGs for " + str(a.scene.meshes.size()) + " meshes");
  for (const PagedMesh& mesh : a.meshes) {
    std::vector<PageData>& roots = a.rootPages.emplace_back();
    for (uint32_t p = 0; p < mesh.table.rootPageCount; ++p) {
      auto page = readPage(*a.reader, mesh, p);
      if (!page) return page.error();
      roots.push_back(std::move(page).value());
    }
  }
  return a;
}

Result<ClusterDag> reassemblePagedDag(const PageTable& table, const PagedDagRest& rest, std::span<const PageData> pages,
                                      const std::string& context) {
  if (pages.size() != table.pages.size())
    return makeError(context, str(pages.size()) + " pages given for " + str(table.pages.size()));
  ClusterDag dag;
  size_t clusterCount = table.clusterPage.size(), groupCount = table.groupLevel.size();
  // Where each cluster sits: its page and its slot there.
  std::vector<uint32_t> slot(clusterCount, kNone);
  for (uint32_t page = 0; page < pages.size(); ++page) {
    const PageData& p = pages[page];
    std::span<const uint32_t> ids = table.clustersOf(page);
    if (p.page != page || p.clusters.size() != ids.size() || !std::equal(ids.begin(), ids.end(), p.clusterIds.begin()))
      return makeError(context, "page " + str(page) + " does not match the page table");
    for (uint32_t i = 0; i < ids.size(); ++i) slot[ids[i]] = i;
  }
  dag.clusters.resize(clusterCount);
  size_t corners = 0;
  for (const PageData& p : pages) corners += p.clusterVertices.size();
  FirstUseIds<3> positionId(corners);
  FirstUseIds<6> vertexId(corners);
  bool normals = table.hasNormals, uv = table.hasUv;
  uint64_t vertexTotal = 0, triangleTotal = 0;
  for (uint32_t c = 0; c < clusterCount; ++c) {
    const PageData& p = pages[table.clusterPage[c]];
    if (slot[c] == kNone || p.page != table.clusterPage[c]) return makeError(context, "cluster " + str(c) + " missing");
    const Cluster& src = p.clusters[slot[c]];
    Cluster& dst = dag.clusters[c];
    dst = src;
    dst.vertexOffset = uint32_t(vertexTotal);
    dst.triangleOffset = uint32_t(triangleTotal);
    vertexTotal += src.vertexCount, triangleTotal += src.triangleCount;
    if (vertexTotal > UINT32_MAX || triangleTotal > UINT32_MAX / 3)
      return makeError(context, "cluster ranges overflow");
    for (uint32_t k = 0; k < src.vertexCount; ++k) {
      uint32_t v = p.clusterVertices[src.vertexOffset + k];
      glm::vec3 pos = p.positions[v];
      glm::vec3 n = normals ? p.normals[v] : glm::vec3(0.0f);
      glm::vec2 t = uv ? p.uv0[v] : glm::vec2(0.0f);
      std::array<uint32_t, 3> pk{bitsOf(pos.x), bitsOf(pos.y), bitsOf(pos.z)};
      auto [position, newPosition] = positionId.insert(pk);
      if (newPosition) dag.positions.push_back(pos);
      auto [vertex, newVertex] =
          vertexId.insert({position, bitsOf(n.x), bitsOf(n.y), bitsOf(n.z), bitsOf(t.x), bitsOf(t.y)});
      if (newVertex) {
        dag.vertexPosition.push_back(position);
        if (normals) dag.normals.push_back(n);
        if (uv) dag.uv0.push_back(t);
      }
      dag.clusterVertices.push_back(vertex);
    }
    const uint8_t* idx = p.clusterIndices.data() + size_t(src.triangleOffset) * 3;
    dag.clusterIndices.insert(dag.clusterIndices.end(), idx, idx + size_t(src.triangleCount) * 3);
  }
  // Groups: members as their page lists them (the DAG's child order), parents ascending (the
  // builder makes a group's parents consecutively).
  if (rest.groupSimplifyError.size() != groupCount) return makeError(context, "group error count mismatch");
  dag.groups.resize(groupCount);
  std::vector<std::vector<uint32_t>> children(groupCount), parents(groupCount);
  for (const PageInfo& info : table.pages) {
    uint32_t at = info.clusterOffset;
    for (uint32_t i = 0; i < info.groupCount; ++i) {
      uint32_t g = table.pageGroups[info.groupOffset + i];
      children[g].assign(table.pageClusters.begin() + at, table.pageClusters.begin() + at + table.groupClusterCount[g]);
      at += table.groupClusterCount[g];
    }
  }
  for (uint32_t c = 0; c < clusterCount; ++c) {
    uint32_t gg = dag.clusters[c].generatingGroup;
    if (gg != kNone) {
      if (gg >= groupCount) return makeError(context, "cluster " + str(c) + " names a missing group");
      parents[gg].push_back(c);
    }
  }
  for (uint32_t g = 0; g < groupCount; ++g) {
    Group& gr = dag.groups[g];
    gr.level = table.groupLevel[g];
    gr.bounds = table.groupBounds[g];
    gr.simplifyError = rest.groupSimplifyError[g];
    gr.childOffset = uint32_t(dag.groupChildren.size());
    gr.childCount = uint32_t(children[g].size());
    dag.groupChildren.insert(dag.groupChildren.end(), children[g].begin(), children[g].end());
    gr.parentOffset = uint32_t(dag.groupParents.size());
    gr.parentCount = uint32_t(parents[g].size());
    dag.groupParents.insert(dag.groupParents.end(), parents[g].begin(), parents[g].end());
  }
  dag.roots = rest.roots;
  dag.levels = rest.levels;
  dag.inputTriangles = rest.inputTriangles;
  if (Status s = checkDagStructure(dag); !s) return makeError(context, s.error().message);
  return dag;
}

Result<ClusterDag> readPagedDag(const asset::AssetReader& reader, const PagedMesh& mesh) {
  std::vector<PageData> pages;
  pages.reserve(mesh.table.pages.size());
  for (uint32_t p = 0; p < mesh.table.pages.size(); ++p) {
    auto page = readPage(reader, mesh, p);
    if (!page) return page.error();
    pages.push_back(std::move(page).value());
  }
  return reassemblePagedDag(mesh.table, mesh.rest, pages, reader.chunkContext(mesh.chunk));
}

std::string dagDifference(const ClusterDag& a, const ClusterDag& b) {
  if (a.clusters.size() != b.clusters.size()) return "cluster counts differ";
  if (a.groups.size() != b.groups.size()) return "group counts differ";
  if (a.clusterIndices != b.clusterIndices) return "cluster indices differ";
  if (a.groupChildren != b.groupChildren) return "group children differ";
  if (a.groupParents != b.groupParents) return "group parents differ";
  if (a.roots != b.roots) return "roots differ";
  if (a.inputTriangles != b.inputTriangles) return "input triangle counts differ";
  if (a.levels.size() != b.levels.size()) return "level counts differ";
  for (size_t l = 0; l < a.levels.size(); ++l) {
    const LevelStats &x = a.levels[l], &y = b.levels[l];
    if (x.clusters != y.clusters || x.triangles != y.triangles || bitsOf(x.meanFill) != bitsOf(y.meanFill) ||
        x.groups != y.groups || x.stuckGroups != y.stuckGroups || bitsOf(x.meanEdgeAge) != bitsOf(y.meanEdgeAge) ||
        bitsOf(x.seconds) != bitsOf(y.seconds))
      return "level " + str(l) + " statistics differ";
  }
  if (a.normals.empty() != b.normals.empty() || a.uv0.empty() != b.uv0.empty()) return "attributes differ";
  auto sameBounds = [](const LodBounds& x, const LodBounds& y) { return std::memcmp(&x, &y, sizeof(LodBounds)) == 0; };
  for (size_t g = 0; g < a.groups.size(); ++g) {
    const Group &x = a.groups[g], &y = b.groups[g];
    if (x.level != y.level || x.childOffset != y.childOffset || x.childCount != y.childCount ||
        x.parentOffset != y.parentOffset || x.parentCount != y.parentCount || !sameBounds(x.bounds, y.bounds) ||
        bitsOf(x.simplifyError) != bitsOf(y.simplifyError))
      return "group " + str(g) + " differs";
  }
  // Vertex numbering may differ: corners must match in value, and welded positions one to one.
  std::vector<uint32_t> positionMap(a.positions.size(), kNone), positionBack(b.positions.size(), kNone);
  for (size_t c = 0; c < a.clusters.size(); ++c) {
    const Cluster &x = a.clusters[c], &y = b.clusters[c];
    if (x.vertexOffset != y.vertexOffset || x.triangleOffset != y.triangleOffset || x.vertexCount != y.vertexCount ||
        x.triangleCount != y.triangleCount || x.level != y.level || x.generatingGroup != y.generatingGroup ||
        x.group != y.group || !sameBounds(x.self, y.self) || !sameBounds(x.parent, y.parent) ||
        !sameBounds(x.bounds, y.bounds))
      return "cluster " + str(c) + " differs";
    for (uint32_t k = 0; k < x.vertexCount; ++k) {
      uint32_t va = a.clusterVertices[x.vertexOffset + k], vb = b.clusterVertices[y.vertexOffset + k];
      uint32_t pa = a.vertexPosition[va], pb = b.vertexPosition[vb];
      std::string corner = "cluster " + str(c) + " vertex " + str(k);
      if (std::memcmp(&a.positions[pa], &b.positions[pb], sizeof(glm::vec3))) return corner + ": positions differ";
      if (positionMap[pa] == kNone) positionMap[pa] = pb;
      if (positionBack[pb] == kNone) positionBack[pb] = pa;
      if (positionMap[pa] != pb || positionBack[pb] != pa) return corner + ": welding differs";
      if (!a.normals.empty() && std::memcmp(&a.normals[va], &b.normals[vb], sizeof(glm::vec3)))
        return corner + ": normals differ";
      if (!a.uv0.empty() && std::memcmp(&a.uv0[va], &b.uv0[vb], sizeof(glm::vec2))) return corner + ": uvs differ";
    }
  }
  return {};
}

} // namespace mirage::lod
