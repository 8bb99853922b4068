// CPU microbenchmarks of the foundation and LOD pieces, on generated inputs (no data files needed).
#include <benchmark/benchmark.h>

#include <random>

#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/io/mesh_utils.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/dag_codec.h"

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

} // namespace
