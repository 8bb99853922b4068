// Build throughput and DAG statistics. Prints, never asserts on time. Disabled by default:
//   build/tests/test_lod --gtest_also_run_disabled_tests --gtest_filter='LodBench.*'
// MIRAGE_LOD_BENCH_MESH=path.ply or MIRAGE_LOD_BENCH_BLOB=subdivisions picks the mesh (default: the
// dragon, else a 1.3M-triangle blob). MIRAGE_LOD_BENCH_THREADS=n runs one build with n threads only.
// MIRAGE_LOD_NORMAL_WEIGHT=w overrides BuildConfig::normalWeight (here and in LodQuality).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "lod_meshes.h"
#include "mirage/lod/cluster_dag.h"
#include "test_support.h"

namespace mirage::lod {
namespace {

// Peak resident set since the last reset, in bytes (Linux: VmHWM; reset by clear_refs "5").
size_t peakRss() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return size_t(std::stoull(line.substr(6))) * 1024;
  return 0;
}
size_t currentRss() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return size_t(std::stoull(line.substr(6))) * 1024;
  return 0;
}
void resetPeak() { std::ofstream("/proc/self/clear_refs") << "5"; }

Mesh benchMesh() {
  if (const char* env = std::getenv("MIRAGE_LOD_BENCH_BLOB")) // subdivisions: 9 = 5.2M, 10 = 21M triangles
    return lodtest::makeBlob(uint32_t(std::atoi(env)), 1);
  if (const char* env = std::getenv("MIRAGE_LOD_BENCH_MESH"))
    if (auto m = lodtest::readAsciiPly(env)) return *m;
  auto dragon = test::sharedFile("stanford-dragon/dragon_vrip.ply");
  if (!dragon.empty())
    if (auto m = lodtest::readAsciiPly(dragon)) return *m;
  return lodtest::makeBlob(8, 1);
}

void report(const Mesh& mesh, const BuildConfig& cfg, bool perLevel) {
  size_t before = currentRss();
  resetPeak();
  auto t0 = std::chrono::steady_clock::now();
  Result<ClusterDag> dag = buildClusterDag(mesh, cfg);
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  size_t peak = peakRss();
  ASSERT_TRUE(dag.ok());
  double tris = double(mesh.triangleCount());
  double fillSum = 0.0;
  for (const LevelStats& l : dag->levels) fillSum += l.meanFill;
  std::printf("%s: %.0f tris, tv=%u gc=%u cv=%u threads=%u: %.3f s, %.2f M tri/s, peak %.0f B/tri (build "
              "%.0f B/tri), %u levels, %zu clusters, root %zu clusters / %llu tris, mean level fill %.2f\n",
              mesh.name.c_str(), tris, cfg.clusterTriangles, cfg.groupClusters, cfg.clusterVertices, cfg.threads, s,
              tris / s * 1e-6, double(peak) / tris, double(peak - std::min(peak, before)) / tris, dag->levelCount(),
              dag->clusters.size(), dag->roots.size(), (unsigned long long)dag->rootTriangles(),
              fillSum / double(std::max<size_t>(1, dag->levels.size())));
  if (!perLevel) return;
  for (size_t i = 0; i < dag->levels.size(); ++i) {
    const LevelStats& l = dag->levels[i];
    std::printf("  level %2zu: %6u clusters %8llu tris fill %.2f groups %5u stuck %3u edge age %.2f %.3f s\n", i,
                l.clusters, (unsigned long long)l.triangles, l.meanFill, l.groups, l.stuckGroups, l.meanEdgeAge,
                l.seconds);
  }
}

BuildConfig benchConfig() {
  BuildConfig cfg;
  if (const char* env = std::getenv("MIRAGE_LOD_NORMAL_WEIGHT")) cfg.normalWeight = float(std::atof(env));
  return cfg;
}

TEST(LodBench, DISABLED_Throughput) {
  Mesh mesh = benchMesh();
  if (const char* env = std::getenv("MIRAGE_LOD_BENCH_THREADS")) { // one run only (profilers, callgrind)
    BuildConfig cfg = benchConfig();
    cfg.threads = uint32_t(std::atoi(env));
    report(mesh, cfg, true);
    return;
  }
  report(mesh, benchConfig(), true);
  if (mesh.triangleCount() > 2'000'000) return; // keep huge runs to a couple of minutes
  BuildConfig one = benchConfig();
  one.threads = 1;
  report(mesh, one, false);
}

TEST(LodBench, DISABLED_ConfigSweep) {
  Mesh mesh = benchMesh();
  for (uint32_t gc : {4u, 8u, 16u, 32u}) {
    BuildConfig cfg;
    cfg.groupClusters = gc;
    report(mesh, cfg, false);
  }
  for (uint32_t cv : {64u, 96u, 128u, 192u, 255u}) {
    BuildConfig cfg;
    cfg.clusterVertices = cv;
    report(mesh, cfg, false);
  }
}

} // namespace
} // namespace mirage::lod
