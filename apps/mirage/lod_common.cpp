#include "lod_common.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>

#include "mirage/asset/container.h"
#include "render_common.h"

namespace mirage::cli {

Result<Scene> loadScenes(const std::vector<std::string>& inputs) {
  Scene merged;
  for (const std::string& input : inputs) {
    auto s = loadSceneArgument(input);
    if (!s) return s.error();
    if (inputs.size() == 1) return s;
    uint32_t meshBase = uint32_t(merged.meshes.size()), materialBase = uint32_t(merged.materials.size());
    int32_t textureBase = int32_t(merged.textures.size());
    for (Mesh& m : s->meshes) {
      m.material += materialBase;
      merged.meshes.push_back(std::move(m));
    }
    for (Material m : s->materials) {
      for (int32_t* t : {&m.baseColorTexture, &m.metallicRoughnessTexture, &m.normalTexture, &m.occlusionTexture,
                         &m.emissiveTexture, &m.detailAlbedoTexture, &m.detailNormalTexture, &m.detailMaskTexture})
        if (*t >= 0) *t += textureBase;
      merged.materials.push_back(m);
    }
    for (Texture& t : s->textures) merged.textures.push_back(std::move(t));
    for (Instance i : s->instances) {
      i.mesh += meshBase;
      merged.instances.push_back(i);
    }
    merged.lights.insert(merged.lights.end(), s->lights.begin(), s->lights.end());
    merged.source += (merged.source.empty() ? "" : "+") + s->source;
  }
  return merged;
}

BuildSummary summarize(const lod::LodAsset& a, const std::string& path) {
  BuildSummary s;
  s.meshes = a.dags.size();
  if (!path.empty()) {
    if (auto reader = asset::AssetReader::open(path)) {
      s.fileBytes = reader->fileBytes();
      for (const asset::ChunkInfo& c : reader->chunks())
        if (c.type == asset::chunk::ClusterDag || c.type == asset::chunk::ClusterPages)
          s.dagBytes += c.storedBytes;
        else if (c.type == asset::chunk::SourceMap)
          s.sourceMapBytes += c.storedBytes;
    }
  }
  for (const std::vector<uint32_t>& map : a.sourceClusters) s.readTriangles += map.size();
  std::vector<double> fillWeighted, ageWeighted;
  for (const lod::ClusterDag& d : a.dags) {
    s.inputTriangles += d.inputTriangles;
    s.clusters += d.clusters.size();
    s.rootClusters += d.roots.size();
    s.rootTriangles += d.rootTriangles();
    if (s.levels.size() < d.levels.size()) s.levels.resize(d.levels.size());
    for (size_t l = 0; l < d.levels.size(); ++l) {
      const lod::LevelStats& ls = d.levels[l];
      LevelSummary& out = s.levels[l];
      double before = double(out.clusters);
      out.clusters += ls.clusters;
      out.triangles += ls.triangles;
      out.meanFill = out.clusters ? (out.meanFill * before + ls.meanFill * ls.clusters) / double(out.clusters) : 0.0;
      out.meanEdgeAge =
          out.clusters ? (out.meanEdgeAge * before + ls.meanEdgeAge * ls.clusters) / double(out.clusters) : 0.0;
      out.stuckGroups += ls.stuckGroups;
      out.seconds += ls.seconds;
    }
  }
  return s;
}

nlohmann::json summaryJson(const BuildSummary& s) {
  nlohmann::json levels = nlohmann::json::array();
  for (const LevelSummary& l : s.levels)
    levels.push_back({{"clusters", l.clusters},
                      {"triangles", l.triangles},
                      {"mean_fill", l.meanFill},
                      {"mean_edge_age", l.meanEdgeAge},
                      {"stuck_groups", l.stuckGroups},
                      {"seconds", l.seconds}});
  return {{"meshes", s.meshes},
          {"read_triangles", s.readTriangles},
          {"input_triangles", s.inputTriangles},
          {"clusters", s.clusters},
          {"levels", levels},
          {"root_clusters", s.rootClusters},
          {"root_triangles", s.rootTriangles},
          {"file_bytes", s.fileBytes},
          {"geometry_bytes", s.dagBytes},
          {"source_map_bytes", s.sourceMapBytes},
          {"geometry_bytes_per_input_triangle", s.inputTriangles ? double(s.dagBytes) / double(s.inputTriangles) : 0.0},
          {"bytes_per_input_triangle", s.inputTriangles ? double(s.fileBytes) / double(s.inputTriangles) : 0.0}};
}

std::string grouped(uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

void printSummary(const BuildSummary& s) {
  // The builder welds positions and drops degenerate and duplicate triangles: both counts, so the
  // import's count and the asset's agree with what each command prints.
  if (s.readTriangles == s.inputTriangles)
    fmt::print("  {} triangles read, none degenerate or duplicate\n", grouped(s.readTriangles));
  else if (s.readTriangles > s.inputTriangles)
    fmt::print("  {} triangles read, {} after removing {} degenerate/duplicate\n", grouped(s.readTriangles),
               grouped(s.inputTriangles), grouped(s.readTriangles - s.inputTriangles));
  else
    fmt::print("  {} triangles (after removing degenerate/duplicate ones)\n", grouped(s.inputTriangles));
  fmt::print("  level  clusters   triangles  fill   edge age  stuck  seconds\n");
  for (size_t l = 0; l < s.levels.size(); ++l) {
    const LevelSummary& v = s.levels[l];
    fmt::print("  {:>5}  {:>8}  {:>10}  {:4.0f}%  {:8.2f}  {:>5}  {:7.3f}\n", l, v.clusters, v.triangles,
               v.meanFill * 100.0, v.meanEdgeAge, v.stuckGroups, v.seconds);
  }
  fmt::print("  root: {} clusters, {} triangles ({:.3f}% of input)\n", s.rootClusters, s.rootTriangles,
             s.inputTriangles ? 100.0 * double(s.rootTriangles) / double(s.inputTriangles) : 0.0);
  if (s.fileBytes) {
    double n = s.inputTriangles ? double(s.inputTriangles) : 1.0;
    fmt::print(
        "  geometry (CDAG or CPAG chunks): {} bytes = {:.2f} bytes per input triangle; whole file {} bytes = {:.2f}\n",
        s.dagBytes, double(s.dagBytes) / n, s.fileBytes, double(s.fileBytes) / n);
    fmt::print("  source-triangle map (TMAP chunk, for cluster PVS): {} bytes = {:.2f} bytes per input triangle\n",
               s.sourceMapBytes, double(s.sourceMapBytes) / n);
  }
}

uint64_t procStatusBytes(const char* field) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return 0;
  char line[256];
  uint64_t kb = 0;
  size_t n = std::strlen(field);
  while (std::fgets(line, sizeof line, f))
    if (std::strncmp(line, field, n) == 0) kb = std::strtoull(line + n + 1, nullptr, 10);
  std::fclose(f);
  return kb * 1024;
}

} // namespace mirage::cli
