#pragma once
// Shared by build, info and bench build: scene merging and cluster-LOD summaries.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mirage/core/result.h"
#include "mirage/lod/lod_asset.h"

namespace mirage::cli {

// Imports every input and merges them into one scene (meshes, materials, textures and instances
// appended, indices offset).
Result<Scene> loadScenes(const std::vector<std::string>& inputs);

struct LevelSummary {
  uint64_t clusters = 0;
  uint64_t triangles = 0;
  double meanFill = 0.0; // cluster-weighted
  double meanEdgeAge = 0.0;
  uint64_t stuckGroups = 0;
  double seconds = 0.0;
};

struct BuildSummary {
  size_t meshes = 0;
  uint64_t readTriangles = 0;  // source triangles as imported (0: unknown, asset without a TMAP chunk)
  uint64_t inputTriangles = 0; // after the builder dropped degenerate and duplicate triangles
  uint64_t clusters = 0;
  uint64_t rootClusters = 0;
  uint64_t rootTriangles = 0;
  uint64_t fileBytes = 0;
  uint64_t dagBytes = 0;            // stored (compressed) bytes of the CDAG chunks: the geometry
  uint64_t sourceMapBytes = 0;      // stored bytes of the TMAP chunk (source triangle -> level-0 cluster)
  std::vector<LevelSummary> levels; // over all meshes
};

// File and geometry sizes are read from the .mrg at `path` (empty: sizes stay 0).
BuildSummary summarize(const lod::LodAsset& asset, const std::string& path);
nlohmann::json summaryJson(const BuildSummary& s);
void printSummary(const BuildSummary& s);
// Resident memory of this process from /proc/self/status ("VmRSS:" now, "VmHWM:" the peak), 0
// where there is none.
uint64_t procStatusBytes(const char* field);
// 102822 -> "102,822".
std::string grouped(uint64_t n);

} // namespace mirage::cli
