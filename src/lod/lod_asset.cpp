#include "mirage/lod/lod_asset.h"

#include <chrono>

#include <nlohmann/json.hpp>

#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"

namespace mirage::lod {

namespace {

nlohmann::json statsJson(const LodAsset& a) {
  nlohmann::json meshes = nlohmann::json::array();
  for (size_t i = 0; i < a.dags.size(); ++i) {
    const ClusterDag& d = a.dags[i];
    nlohmann::json levels = nlohmann::json::array();
    for (const LevelStats& l : d.levels)
      levels.push_back({{"clusters", l.clusters},
                        {"triangles", l.triangles},
                        {"mean_fill", l.meanFill},
                        {"groups", l.groups},
                        {"stuck_groups", l.stuckGroups},
                        {"mean_edge_age", l.meanEdgeAge},
                        {"seconds", l.seconds}});
    meshes.push_back({{"name", a.scene.meshes[i].name},
                      {"input_triangles", d.inputTriangles},
                      {"clusters", d.clusters.size()},
                      {"groups", d.groups.size()},
                      {"root_clusters", d.roots.size()},
                      {"root_triangles", d.rootTriangles()},
                      {"levels", levels}});
  }
  return meshes;
}

} // namespace

Result<LodAsset> bakeLodAsset(const Scene& scene, const BuildConfig& config, const BuildProgress& progress) {
  LodAsset out;
  out.scene = scene;
  uint64_t total = scene.meshTriangleCount(), done = 0;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& mesh = scene.meshes[i];
    auto dag = buildClusterDag(mesh, config);
    if (!dag)
      return Error{scene.source + ": mesh " + std::to_string(i) + " '" + mesh.name + "': " + dag.error().message};
    out.dags.push_back(std::move(dag).value());
    done += mesh.triangleCount();
    if (progress) progress(i + 1, scene.meshes.size(), done, total);
  }
  // Geometry now lives in the DAGs; the scene chunk keeps what the renderer needs beside them.
  for (Mesh& m : out.scene.meshes) {
    Bounds keep = m.bounds;
    m = Mesh{m.name, {}, {}, {}, {}, {}, {}, m.material, keep};
  }
  nlohmann::json meta = {{"format", "mirage cluster LOD"},
                         {"dag_codec_version", kDagCodecVersion},
                         {"source", scene.source},
                         {"config",
                          {{"cluster_triangles", config.clusterTriangles},
                           {"cluster_vertices", config.clusterVertices},
                           {"group_clusters", config.groupClusters},
                           {"stuck_ratio", config.stuckRatio},
                           {"normal_weight", config.normalWeight}}},
                         {"meshes", statsJson(out)}};
  out.metaJson = meta.dump();
  return out;
}

Status saveLodAsset(const std::string& path, const LodAsset& a, const DagEncodeOptions& options) {
  if (a.dags.size() != a.scene.meshes.size()) return makeError(path, "one DAG per mesh required");
  if (Status s = asset::validateScene(a.scene, path); !s) return s;
  asset::AssetWriter w;
  std::vector<uint8_t> sceneBytes = asset::encodeScene(a.scene);
  w.addChunk(asset::chunk::Scene, sceneBytes);
  std::vector<std::vector<uint8_t>> dagBytes(a.dags.size());
  for (size_t i = 0; i < a.dags.size(); ++i) {
    dagBytes[i] = encodeDag(a.dags[i], options);
    // Measured on the dragon's chunk (13 MB raw): level 3 -> 12.82 B/triangle in 0.06 s, 9 -> 12.19
    // in 0.29 s, 19 -> 11.82 in 4.8 s (2.8 MB/s: ~2 minutes for a 21 M-triangle mesh). Level 19 only
    // where it costs at most about a second; decoding speed is the same.
    int level = dagBytes[i].size() <= (4u << 20) ? 19 : 9;
    w.addChunk(asset::chunk::ClusterDag, dagBytes[i], level);
  }
  std::string meta = a.metaJson.empty() ? "{}" : a.metaJson;
  w.addChunk(asset::chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(meta.data()), meta.size()));
  return w.write(path);
}

Result<LodAsset> loadLodAsset(const std::string& path) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  LodAsset a;
  auto sceneBytes = reader->readChunk(asset::chunk::Scene);
  if (!sceneBytes) return sceneBytes.error();
  auto scene = asset::decodeScene(*sceneBytes, path);
  if (!scene) return scene.error();
  a.scene = std::move(scene).value();
  for (size_t i = 0; i < reader->chunks().size(); ++i) {
    asset::FourCC type = reader->chunks()[i].type;
    if (type == asset::chunk::ClusterDag) {
      auto bytes = reader->readChunk(i);
      if (!bytes) return bytes.error();
      auto dag = decodeDag(*bytes, path);
      if (!dag) return dag.error();
      a.dags.push_back(std::move(dag).value());
    } else if (type == asset::chunk::Meta) {
      auto bytes = reader->readChunk(i);
      if (!bytes) return bytes.error();
      a.metaJson.assign(bytes->begin(), bytes->end());
    }
  }
  if (a.dags.empty()) return makeError(path, "no cluster DAG chunk (not built with mirage build?)");
  if (a.dags.size() != a.scene.meshes.size())
    return makeError(path, std::to_string(a.dags.size()) + " cluster DAGs for " +
                               std::to_string(a.scene.meshes.size()) + " meshes");
  return a;
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
