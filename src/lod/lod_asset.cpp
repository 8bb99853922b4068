#include "mirage/lod/lod_asset.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/lod/paged_asset.h"
#include "asset_parts.h"

namespace mirage::lod {

namespace {

std::vector<uint8_t> encodeSourceMaps(const std::vector<std::vector<uint32_t>>& maps) {
  asset::ByteWriter w = sourceMapHeader(maps.size());
  for (const std::vector<uint32_t>& map : maps) writeSourceMap(w, map);
  return w.take();
}

Result<std::vector<std::vector<uint32_t>>> decodeSourceMaps(std::span<const uint8_t> bytes, const LodAsset& a,
                                                            const std::string& path) {
  asset::ByteReader r(bytes, path);
  uint32_t version = 0;
  if (!r.read(version)) return r.error();
  if (version != kSourceMapVersion)
    return makeError(path, "source-triangle map version " + std::to_string(version) + " (this build reads " +
                               std::to_string(kSourceMapVersion) + ")");
  uint64_t meshes = 0;
  if (!r.readCount(meshes, a.dags.size(), "source map mesh count")) return r.error();
  if (meshes != a.dags.size())
    return makeError(path, "source-triangle maps for " + std::to_string(meshes) + " of " +
                               std::to_string(a.dags.size()) + " meshes");
  std::vector<std::vector<uint32_t>> maps(meshes);
  for (size_t m = 0; m < meshes; ++m) {
    uint64_t n = 0;
    if (!r.readCount(n, r.remaining(), "source triangle count")) return r.error();
    maps[m].resize(n);
    int64_t prev = 0;
    uint64_t clusters = a.dags[m].clusters.size();
    for (uint64_t t = 0; t < n; ++t) {
      uint64_t z = 0;
      if (!r.readVarint(z)) return r.error();
      int64_t v = prev + (int64_t(z >> 1) ^ -int64_t(z & 1));
      if (v < 0 || uint64_t(v) > clusters || (v > 0 && a.dags[m].clusters[size_t(v - 1)].level != 0))
        return makeError(path, "source-triangle map of mesh " + std::to_string(m) + " names a bad cluster");
      maps[m][t] = uint32_t(v - 1);
      prev = v;
    }
  }
  if (Status s = r.finish(); !s) return s.error();
  return maps;
}

} // namespace

nlohmann::json meshStatsJson(const std::string& name, const ClusterDag& d) {
  nlohmann::json levels = nlohmann::json::array();
  for (const LevelStats& l : d.levels)
    levels.push_back({{"clusters", l.clusters},
                      {"triangles", l.triangles},
                      {"mean_fill", l.meanFill},
                      {"groups", l.groups},
                      {"stuck_groups", l.stuckGroups},
                      {"mean_edge_age", l.meanEdgeAge}}); // no timings: a bake writes the same bytes every time
  return {{"name", name},
          {"input_triangles", d.inputTriangles},
          {"clusters", d.clusters.size()},
          {"groups", d.groups.size()},
          {"root_clusters", d.roots.size()},
          {"root_triangles", d.rootTriangles()},
          {"levels", levels}};
}

std::string lodMetaJson(const std::string& source, const BuildConfig& config, nlohmann::json meshes) {
  nlohmann::json meta = {{"format", "mirage cluster LOD"},
                         {"dag_codec_version", kDagCodecVersion},
                         {"source", source},
                         {"config",
                          {{"cluster_triangles", config.clusterTriangles},
                           {"cluster_vertices", config.clusterVertices},
                           {"group_clusters", config.groupClusters},
                           {"coarse_groups_from_level", config.coarseGroupsFromLevel},
                           {"coarser_groups_from_level", config.coarserGroupsFromLevel},
                           {"stuck_ratio", config.stuckRatio},
                           {"normal_weight", config.normalWeight}}},
                         {"meshes", std::move(meshes)}};
  return meta.dump();
}

// 'TMAP': u32 version, varint mesh count, per mesh: varint triangles, then per triangle
// zigzag(cluster + 1 - previous) as a varint (neighbouring source triangles mostly share a cluster,
// and the container's zstd takes the rest).
asset::ByteWriter sourceMapHeader(size_t meshCount) {
  asset::ByteWriter w;
  w.write(kSourceMapVersion);
  w.writeVarint(meshCount);
  return w;
}

void writeSourceMap(asset::ByteWriter& w, std::span<const uint32_t> map) {
  w.writeVarint(map.size());
  int64_t prev = 0;
  for (uint32_t c : map) {
    int64_t v = int64_t(uint32_t(c + 1)), d = v - prev; // kNone + 1 wraps to 0
    w.writeVarint((uint64_t(d) << 1) ^ uint64_t(d >> 63));
    prev = v;
  }
}

std::vector<uint32_t> sourceTriangleClusters(const Mesh& mesh, const ClusterDag& dag) {
  using Key = std::array<uint32_t, 3>;
  auto key = [&](uint32_t a, uint32_t b, uint32_t c) {
    Key k{dag.vertexPosition[a], dag.vertexPosition[b], dag.vertexPosition[c]};
    std::sort(k.begin(), k.end());
    return k;
  };
  // Parallel throughout (the bake runs it on every mesh, 21 M triangles take seconds serially):
  // each level-0 cluster writes its triangles' keys at its own offset, then one parallel sort
  // (the pairs are totally ordered, so the result does not depend on the schedule) and
  // independent lookups.
  std::vector<size_t> first{0}; // per level-0 cluster: its first entry in level0
  for (uint32_t c = 0; c < dag.clusters.size() && dag.clusters[c].level == 0; ++c)
    first.push_back(first.back() + dag.clusters[c].triangleCount);
  std::vector<std::pair<Key, uint32_t>> level0(first.back()); // sorted welded triple -> cluster
  tbb::parallel_for(size_t(0), first.size() - 1, [&](size_t c) {
    const Cluster& cl = dag.clusters[c];
    const uint32_t* v = &dag.clusterVertices[cl.vertexOffset];
    for (uint32_t t = 0; t < cl.triangleCount; ++t) {
      const uint8_t* local = &dag.clusterIndices[(size_t(cl.triangleOffset) + t) * 3];
      level0[first[c] + t] = {key(v[local[0]], v[local[1]], v[local[2]]), uint32_t(c)};
    }
  });
  tbb::parallel_sort(level0.begin(), level0.end());
  std::vector<uint32_t> out(mesh.indices.size() / 3, kNone);
  tbb::parallel_for(size_t(0), out.size(), [&](size_t t) {
    Key k = key(mesh.indices[t * 3], mesh.indices[t * 3 + 1], mesh.indices[t * 3 + 2]);
    if (k[0] == k[1] || k[1] == k[2]) return; // degenerate: dropped by the builder, covers no pixel
    auto it = std::lower_bound(level0.begin(), level0.end(), std::pair<Key, uint32_t>{k, 0});
    if (it != level0.end() && it->first == k) out[t] = it->second;
  });
  return out;
}

std::string meshWhere(const Scene& scene, size_t mesh) {
  return scene.source + ": mesh " + std::to_string(mesh) + " '" + scene.meshes[mesh].name + "'";
}

Result<BakedMesh> bakeLodMesh(const Mesh& mesh, const std::string& where, const BuildConfig& config) {
  // The builder knows where each source triangle went (sourceTriangleClusters recomputes the
  // same map by sorting triangle keys: 9 % of the bake's instructions on the dragon).
  BakedMesh out;
  auto dag = buildClusterDag(mesh, config, &out.sourceClusters);
  if (!dag) return Error{where + ": " + dag.error().message};
  out.dag = std::move(dag).value();
  return out;
}

LodAsset assembleLodAsset(const Scene& scene, const BuildConfig& config, std::vector<BakedMesh> meshes) {
  assert(meshes.size() == scene.meshes.size());
  LodAsset out;
  // Geometry lives in the DAGs; the scene chunk keeps what the renderer needs beside them. Built
  // without copying the meshes' arrays (a serial 20 MB copy on the dragon, then freed).
  out.scene.source = scene.source;
  out.scene.materials = scene.materials;
  out.scene.textures = scene.textures;
  out.scene.instances = scene.instances;
  out.scene.lights = scene.lights;
  for (const Mesh& m : scene.meshes)
    out.scene.meshes.push_back(Mesh{m.name, {}, {}, {}, {}, {}, {}, m.material, m.bounds});
  for (BakedMesh& m : meshes) {
    out.dags.push_back(std::move(m.dag));
    out.sourceClusters.push_back(std::move(m.sourceClusters));
  }
  nlohmann::json stats = nlohmann::json::array();
  for (size_t i = 0; i < out.dags.size(); ++i) stats.push_back(meshStatsJson(out.scene.meshes[i].name, out.dags[i]));
  out.metaJson = lodMetaJson(scene.source, config, std::move(stats));
  return out;
}

Result<LodAsset> bakeLodAsset(const Scene& scene, const BuildConfig& config, const BuildProgress& progress) {
  std::vector<BakedMesh> meshes;
  uint64_t total = scene.meshTriangleCount(), done = 0;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    auto baked = bakeLodMesh(scene.meshes[i], meshWhere(scene, i), config);
    if (!baked) return baked.error();
    meshes.push_back(std::move(baked).value());
    done += scene.meshes[i].triangleCount();
    if (progress) progress(i + 1, scene.meshes.size(), done, total);
  }
  return assembleLodAsset(scene, config, std::move(meshes));
}

namespace {

// The asset of an open container; `path` names the file in errors.
Result<LodAsset> readLodAsset(const asset::AssetReader& reader, const std::string& path) {
  LodAsset a;
  auto sceneBytes = reader.readChunk(asset::chunk::Scene);
  if (!sceneBytes) return sceneBytes.error();
  auto scene = asset::decodeScene(*sceneBytes, path);
  if (!scene) return scene.error();
  a.scene = std::move(scene).value();
  for (size_t i = 0; i < reader.chunks().size(); ++i) {
    asset::FourCC type = reader.chunks()[i].type;
    if (type == asset::chunk::ClusterDag) {
      auto bytes = reader.readChunk(i);
      if (!bytes) return bytes.error();
      auto dag = decodeDag(*bytes, path);
      if (!dag) return dag.error();
      a.dags.push_back(std::move(dag).value());
    } else if (type == asset::chunk::Meta) {
      auto bytes = reader.readChunk(i);
      if (!bytes) return bytes.error();
      a.metaJson.assign(bytes->begin(), bytes->end());
    }
  }
  if (a.dags.empty()) { // a paged file: every page read, checked and reassembled
    auto paged = openPagedMeshes(reader);
    if (!paged) return paged.error();
    for (const PagedMesh& mesh : *paged) {
      auto dag = readPagedDag(reader, mesh);
      if (!dag) return dag.error();
      a.dags.push_back(std::move(dag).value());
    }
  }
  if (a.dags.empty()) return makeError(path, "no cluster DAG chunk (not built with mirage build?)");
  if (a.dags.size() != a.scene.meshes.size())
    return makeError(path, std::to_string(a.dags.size()) + " cluster DAGs for " +
                               std::to_string(a.scene.meshes.size()) + " meshes");
  if (reader.find(asset::chunk::SourceMap)) {
    auto bytes = reader.readChunk(asset::chunk::SourceMap);
    if (!bytes) return bytes.error();
    auto maps = decodeSourceMaps(*bytes, a, path);
    if (!maps) return maps.error();
    a.sourceClusters = std::move(*maps);
  }
  return a;
}

} // namespace

std::string dagReadBackDifference(const ClusterDag& a, const ClusterDag& b, bool paged) {
  if (paged) {
    if (a.clusters.size() != b.clusters.size() || a.clusterIndices != b.clusterIndices ||
        a.groupChildren != b.groupChildren || a.groupParents != b.groupParents || a.roots != b.roots ||
        a.normals.empty() != b.normals.empty() || a.uv0.empty() != b.uv0.empty())
      return "paged cluster DAG decodes differently";
    return {};
  }
  if (a.positions.size() != b.positions.size() || a.vertexPosition != b.vertexPosition ||
      a.clusters.size() != b.clusters.size() || a.clusterVertices != b.clusterVertices ||
      a.clusterIndices != b.clusterIndices || a.groups.size() != b.groups.size() ||
      a.groupChildren != b.groupChildren || a.groupParents != b.groupParents || a.roots != b.roots ||
      a.normals.size() != b.normals.size() || a.uv0 != b.uv0)
    return "cluster DAG decodes differently";
  return {};
}

namespace {

// What a reader of the written file gets is what was baked: the same counts and topology
// (positions moved only within the grid's slack, which decodeDag accounts for).
// A paged DAG numbers its vertices anew (reassemblePagedDag): the same clusters, links and indices.
std::string readBackDifference(const LodAsset& written, const LodAsset& read, bool paged) {
  if (read.dags.size() != written.dags.size()) return "mesh count differs";
  for (size_t i = 0; i < written.dags.size(); ++i)
    if (std::string d = dagReadBackDifference(written.dags[i], read.dags[i], paged); !d.empty())
      return "mesh " + std::to_string(i) + "'s " + d;
  if (read.sourceClusters != written.sourceClusters) return "source-triangle maps differ";
  return {};
}

} // namespace

Status saveLodAsset(const std::string& path, const LodAsset& a, const LodWriteOptions& options) {
  if (a.dags.size() != a.scene.meshes.size()) return makeError(path, "one DAG per mesh required");
  if (Status s = asset::validateScene(a.scene, path); !s) return s;
  asset::AssetWriter w;
  std::vector<uint8_t> sceneBytes = asset::encodeScene(a.scene);
  w.addChunk(asset::chunk::Scene, sceneBytes);
  PageConfig pageConfig = options.pages;
  pageConfig.positionBits = options.dag.positionBits;
  // Each mesh's chunk encoded and compressed on its own thread (zstd at level 19 is most of the
  // write: 16 terrains of 72 k triangles, 9 of 12 s), then added in mesh order: the same bytes.
  std::vector<Result<asset::StoredChunk>> dagChunks(a.dags.size(), Error{});
  std::vector<Result<std::vector<uint8_t>>> pagedChunks(a.dags.size(), Error{});
  tbb::task_arena arena(options.threads ? int(options.threads) : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(size_t(0), a.dags.size(), [&](size_t i) {
      // Level 9, the CDAG chunk's level for large meshes: on the dragon's pages 19 saves 4.4 % (15.40
      // -> 14.72 MB file) for 1.2 s more write time (one thread).
      if (options.paged) return void(pagedChunks[i] = encodePagedChunk(a.dags[i], pageConfig, 9));
      std::vector<uint8_t> bytes = encodeDag(a.dags[i], options.dag);
      // Measured on the dragon's chunk (13 MB raw): level 3 -> 12.82 B/triangle in 0.06 s, 9 -> 12.19
      // in 0.29 s, 19 -> 11.82 in 4.8 s (2.8 MB/s: ~2 minutes for a 21 M-triangle mesh). Level 19
      // only where it costs at most about a second; decoding speed is the same.
      int level = bytes.size() <= (4u << 20) ? 19 : 9;
      dagChunks[i] = asset::storeChunk(asset::chunk::ClusterDag, bytes, level);
    });
  });
  for (size_t i = 0; i < a.dags.size(); ++i) {
    if (options.paged) {
      if (!pagedChunks[i])
        return makeError(path, "mesh " + std::to_string(i) + ": paged cluster DAG: " + pagedChunks[i].error().message);
      w.addBlockedChunk(asset::chunk::ClusterPages, std::move(pagedChunks[i]).value(), 9);
    } else {
      if (!dagChunks[i]) return makeError(path, dagChunks[i].error().message);
      w.addStoredChunk(dagChunks[i]->info, std::move(dagChunks[i]->stored));
    }
  }
  std::vector<uint8_t> mapBytes;
  if (!a.sourceClusters.empty()) {
    if (a.sourceClusters.size() != a.dags.size()) return makeError(path, "one source-triangle map per mesh required");
    mapBytes = encodeSourceMaps(a.sourceClusters);
    w.addChunk(asset::chunk::SourceMap, mapBytes);
  }
  std::string meta = a.metaJson.empty() ? "{}" : a.metaJson;
  w.addChunk(asset::chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(meta.data()), meta.size()));
  // Read the complete file back before it takes the name: a file that `info`, `verify` or `render`
  // would reject is never published (the encoder once wrote positions one step off its grid).
  return w.write(path, [&](const std::string& tempPath) -> Status {
    auto reader = asset::AssetReader::open(tempPath);
    Result<LodAsset> read = reader ? readLodAsset(*reader, path) : Result<LodAsset>(reader.error());
    std::string problem = read ? readBackDifference(a, *read, options.paged) : read.error().message;
    if (problem.empty()) return Ok{};
    if (problem.starts_with(path + ": ")) problem.erase(0, path.size() + 2); // named once, in front
    return makeError(path, "the written file does not read back (" + problem + "); nothing written");
  });
}

Result<LodAsset> loadLodAsset(const std::string& path, const asset::SourceOptions& options) {
  auto reader = asset::AssetReader::open(path, options);
  if (!reader) return reader.error();
  return readLodAsset(*reader, path);
}

Mesh levelZeroMesh(const ClusterDag& dag) {
  Mesh m;
  m.name = "level 0";
  m.positions.resize(dag.vertexPosition.size());
  for (size_t i = 0; i < m.positions.size(); ++i) m.positions[i] = dag.positions[dag.vertexPosition[i]];
  for (const Cluster& c : dag.clusters) {
    if (c.level != 0) continue;
    for (uint32_t t = 0; t < uint32_t(c.triangleCount) * 3; ++t)
      m.indices.push_back(dag.clusterVertices[c.vertexOffset + dag.clusterIndices[size_t(c.triangleOffset) * 3 + t]]);
  }
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

Scene levelZeroScene(const LodAsset& asset) {
  Scene scene = asset.scene;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    uint32_t material = scene.meshes[m].material;
    scene.meshes[m] = levelZeroMesh(asset.dags[m]);
    scene.meshes[m].normals = asset.dags[m].normals;
    scene.meshes[m].uv0 = asset.dags[m].uv0;
    scene.meshes[m].material = material;
  }
  return scene;
}

Mesh cutMesh(const ClusterDag& dag, const std::vector<uint32_t>& clusters) {
  Mesh m;
  m.name = "cut";
  std::vector<uint32_t> remap(dag.vertexPosition.size(), UINT32_MAX);
  for (uint32_t id : clusters) {
    const Cluster& c = dag.clusters[id];
    for (uint32_t t = 0; t < uint32_t(c.triangleCount) * 3; ++t) {
      uint32_t v = dag.clusterVertices[c.vertexOffset + dag.clusterIndices[size_t(c.triangleOffset) * 3 + t]];
      if (remap[v] == UINT32_MAX) {
        remap[v] = uint32_t(m.positions.size());
        m.positions.push_back(dag.positions[dag.vertexPosition[v]]);
        if (!dag.normals.empty()) m.normals.push_back(dag.normals[v]);
        if (!dag.uv0.empty()) m.uv0.push_back(dag.uv0[v]);
      }
      m.indices.push_back(remap[v]);
    }
  }
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  return m;
}

} // namespace mirage::lod
