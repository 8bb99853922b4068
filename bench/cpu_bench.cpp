// CPU microbenchmarks of the foundation and LOD pieces, on generated inputs (no data files needed).
#include <benchmark/benchmark.h>

#include <random>

#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/io/mesh_utils.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/residency.h"

using namespace mirage;

namespace {

ImageRGBA8 noiseImage(uint32_t w, uint32_t h, uint32_t seed) {
  ImageRGBA8 img{w, h, std::vector<uint8_t>(size_t(w) * h * 4)};
  std::mt19937 rng(seed);
  for (auto& p : img.pixels) p = uint8_t(rng());
  return img;
}

Mesh blob(uint32_t subdivisions) { return io::generateScene("blob", 1, subdivisions).value().meshes[0]; }

void BM_Ssim1080p(benchmark::State& state) {
  ImageRGBA8 a = noiseImage(1920, 1080, 1), b = noiseImage(1920, 1080, 2);
  for (auto _ : state) benchmark::DoNotOptimize(ssim(a, b));
  state.SetItemsProcessed(state.iterations() * 1920 * 1080);
}
BENCHMARK(BM_Ssim1080p)->Unit(benchmark::kMillisecond);

void BM_WeldMesh(benchmark::State& state) {
  Mesh source = blob(uint32_t(state.range(0)));
  // Unweld: every triangle gets its own three vertices, as many exporters write them.
  Mesh soup;
  for (uint32_t i : source.indices) {
    soup.positions.push_back(source.positions[i]);
    soup.normals.push_back(source.normals[i]);
    soup.indices.push_back(uint32_t(soup.indices.size()));
  }
  for (auto _ : state) {
    Mesh m = soup;
    io::weldMesh(m);
    benchmark::DoNotOptimize(m.positions.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(soup.triangleCount()));
}
BENCHMARK(BM_WeldMesh)->Arg(6)->Arg(8)->Unit(benchmark::kMillisecond);

void BM_BuildClusterDag(benchmark::State& state) {
  Mesh m = blob(uint32_t(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(lod::buildClusterDag(m).ok());
  state.SetItemsProcessed(state.iterations() * int64_t(m.triangleCount()));
}
BENCHMARK(BM_BuildClusterDag)->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond);

void BM_DagEncodeDecode(benchmark::State& state) {
  Mesh m = blob(7);
  lod::ClusterDag dag = lod::buildClusterDag(m).value();
  size_t bytes = 0;
  for (auto _ : state) {
    std::vector<uint8_t> encoded = lod::encodeDag(dag);
    bytes = encoded.size();
    benchmark::DoNotOptimize(lod::decodeDag(encoded, "bench").ok());
  }
  state.counters["bytes_per_triangle"] = double(bytes) / double(m.triangleCount());
  state.SetItemsProcessed(state.iterations() * int64_t(m.triangleCount()));
}
BENCHMARK(BM_DagEncodeDecode)->Unit(benchmark::kMillisecond);

// One residency step at gen:many:512x2000000's scale: 512 meshes of 150 pages (page p depends on
// page p / 2, page 0 the root), 200 KB each, a budget of 10 000 pages kept full, and a camera cut's
// feedback: 300 missing pages asked for, 2 000 resident ones used.
void BM_ResidencyStepAtScale(benchmark::State& state) {
  const uint32_t meshes = 512, perMesh = 150;
  lod::ResidencyGraph g;
  g.dependencyOffset.push_back(0);
  for (uint32_t m = 0; m < meshes; ++m) {
    g.pageOffset.push_back(m * perMesh);
    for (uint32_t p = 0; p < perMesh; ++p) {
      g.bytes.push_back(200 * 1024);
      g.root.push_back(p == 0);
      if (p > 0) g.dependencies.push_back(m * perMesh + p / 2);
      g.dependencyOffset.push_back(uint32_t(g.dependencies.size()));
    }
  }
  auto manager = lod::ResidencyManager::create(g, {.budgetBytes = 10000ull * 200 * 1024, .maxLoadsPerStep = 32});
  std::mt19937 rng(1);
  std::vector<float> feedback(g.pageCount());
  auto cut = [&] {
    std::fill(feedback.begin(), feedback.end(), 0.0f);
    uint32_t asked = 0, used = 0;
    while (asked < 300 || used < 2000) {
      uint32_t p = uint32_t(rng() % g.pageCount());
      bool resident = manager->isResident(p);
      if (resident ? used++ < 2000 : asked++ < 300) feedback[p] = 1.0f + float(rng() % 1000);
    }
  };
  for (int i = 0; i < 2000; ++i) cut(), manager->step(feedback); // fill the budget
  for (auto _ : state) {
    state.PauseTiming();
    cut();
    state.ResumeTiming();
    benchmark::DoNotOptimize(manager->step(feedback).loaded.size());
  }
  state.counters["resident_pages"] = manager->residentPages();
}
BENCHMARK(BM_ResidencyStepAtScale)->Unit(benchmark::kMillisecond);

} // namespace
