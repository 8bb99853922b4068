// Build profiling sums and their report (build_profile.h).
#include "build_profile.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace mirage::lod::detail {

namespace {

constexpr const char* kStageNames[kStageCount] = {"weld+clean",
                                                  "level-0 split",
                                                  "level-0 append (serial)",
                                                  "cluster borders",
                                                  "grouping (partly serial)",
                                                  "METIS (one thread)",
                                                  "touch counts",
                                                  "group gather",
                                                  "simplify",
                                                  "group split",
                                                  "commit (serial)",
                                                  "source map"};
constexpr const char* kWallNames[kWallCount] = {"weld+clean", "level 0", "grouping", "METIS+simplify+split",
                                                "ages+commit"};
} // namespace

std::atomic<int64_t> gStageNs[kStageCount];
std::atomic<double> gWallSeconds[kWallCount], gWallCpuSeconds[kWallCount];

void printStages(uint64_t triangles) {
  if (!std::getenv("MIRAGE_LOD_PROFILE")) {
    for (int i = 0; i < kWallCount; ++i) gWallSeconds[i] = 0.0, gWallCpuSeconds[i] = 0.0;
    return;
  }
  std::fprintf(stderr, "lod wall seconds (process CPU seconds):");
  for (int i = 0; i < kWallCount; ++i) {
    std::fprintf(stderr, " %s %.3f (%.3f)%s", kWallNames[i], gWallSeconds[i].exchange(0.0),
                 gWallCpuSeconds[i].exchange(0.0), i + 1 < kWallCount ? "," : "\n");
  }
  double total = 0.0;
  for (auto& ns : gStageNs) total += double(ns.load()) * 1e-9;
  std::fprintf(stderr, "lod stages (thread CPU seconds, %llu tris):", (unsigned long long)triangles);
  for (int i = 0; i < kStageCount; ++i) {
    double sec = double(gStageNs[i].exchange(0)) * 1e-9;
    std::fprintf(stderr, " %s %.3f (%.0f%%)%s", kStageNames[i], sec, 100.0 * sec / std::max(total, 1e-9),
                 i + 1 < kStageCount ? "," : "\n");
  }
}

} // namespace mirage::lod::detail
