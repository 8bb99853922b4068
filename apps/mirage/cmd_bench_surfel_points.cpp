// mirage bench surfels-points SCAN.ply: the two point-cloud paths of the surfel sampler on the same
// scan in one run: the exact CPU farthest-point order over the points against the GPU path (discs
// splatted into the G-buffers, then the GPU sampler), with wall times, per-stage GPU times
// (timestamp queries) and the quality of both orders' prefixes.
#include <chrono>

#include <fmt/format.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/reference.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct BenchPointsOptions {
  std::string input;
  uint32_t count = 100000;
  uint32_t resolution = 1024;
  uint32_t views = 16;
  float threshold = 0.75f;
  bool skipCpu = false; // the exact CPU order takes minutes on 10 M points with few cores
  std::string device;
};

void printPrefixes(const surfels::GBufferTexels* cpuTexels, const surfels::SampleOrder* cpu,
                   const surfels::GBufferTexels& gpuTexels, const surfels::SampleOrder& gpu) {
  fmt::print("{:>8} {:>9} {:>12} {:>9} {:>12}\n", "prefix", "cpu rho", "cpu coverage", "gpu rho", "gpu coverage");
  std::vector<uint32_t> prefixes;
  for (uint32_t n : {100u, 1000u, 10000u, 100000u, 1000000u})
    if (n < gpu.texels.size()) prefixes.push_back(n);
  prefixes.push_back(uint32_t(gpu.texels.size()));
  for (uint32_t n : prefixes) {
    if (n == 0) continue;
    surfels::PrefixQuality g = surfels::measurePrefix(gpuTexels, gpu, n);
    if (cpu && n <= cpu->texels.size()) {
      surfels::PrefixQuality c = surfels::measurePrefix(*cpuTexels, *cpu, n);
      fmt::print("{:>8} {:>9.3f} {:>12.4f} {:>9.3f} {:>12.4f}\n", n, c.rho, c.coverage, g.rho, g.coverage);
    } else {
      fmt::print("{:>8} {:>9} {:>12} {:>9.3f} {:>12.4f}\n", n, "-", "-", g.rho, g.coverage);
    }
  }
}

void runBenchPoints(const BenchPointsOptions& o) {
  if (o.count == 0) return fail("--count must be at least 1");
  if (o.views == 0 || o.views > 256) return fail("--views must be in 1..256");
  if (o.resolution == 0) return fail("--resolution must be at least 1");
  if (!(o.threshold > 0.0f && o.threshold <= 1.0f)) return fail("--threshold must be in (0, 1]");
  auto t0 = std::chrono::steady_clock::now();
  io::ImportOptions importOptions;
  importOptions.allowPointClouds = true;
  auto scene = loadSceneArgument(o.input, importOptions);
  if (!scene) return fail(scene.error());
  if (!surfels::isPointCloud(*scene)) return fail(o.input + ": not a point cloud (a PLY without faces)");
  double importSeconds = secondsSince(t0);
  t0 = std::chrono::steady_clock::now();
  auto points = surfels::scanPoints(*scene);
  if (!points) return fail(points.error());
  double spacingSeconds = secondsSince(t0);
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  gpu::Context& c = **ctx;
  fmt::print("{}: {} points ({}) on {}; import {:.3f} s, k-NN spacing (both paths) {:.3f} s\n", o.input, points->size(),
             points->hasNormals ? "normals from the file" : "normals estimated: two-sided discs", c.caps().name,
             importSeconds, spacingSeconds);

  // The exact CPU path.
  surfels::GBufferTexels cpuTexels;
  surfels::SampleOrder cpuOrder;
  double cpuSeconds = 0.0;
  if (!o.skipCpu) {
    t0 = std::chrono::steady_clock::now();
    cpuTexels = surfels::pointCloudTexels(*points);
    cpuOrder = surfels::farthestPointReference(cpuTexels, o.count);
    cpuSeconds = secondsSince(t0);
    fmt::print("cpu  exact farthest-point order: {} surfels, {:.3f} s wall (A = {:.6g})\n", cpuOrder.texels.size(),
               cpuSeconds, cpuTexels.totalArea);
  }

  // The GPU path: disc capture, then the sampler.
  surfels::CaptureConfig cc;
  cc.resolution = o.resolution;
  cc.views = o.views;
  t0 = std::chrono::steady_clock::now();
  auto gb = surfels::capturePointCloud(c, *points, cc);
  if (!gb) return fail(gb.error());
  double captureSeconds = secondsSince(t0);
  surfels::GpuSamplerConfig sc;
  sc.count = o.count;
  sc.threshold = o.threshold;
  auto sampled = surfels::sampleOnGpu(c, *gb, sc);
  if (!sampled) return fail(sampled.error());
  double gpuSeconds = captureSeconds + sampled->seconds;
  fmt::print("gpu  {} views x {}^2: {} texels (A = {:.6g}), {} surfels in {} rounds; capture {:.3f} s wall (GPU, "
             "readback, areas), sampler {:.3f} s wall\n",
             o.views, o.resolution, gb->texels.size(), gb->texels.totalArea, sampled->order.texels.size(),
             sampled->rounds, captureSeconds, sampled->seconds);
  double gpuMs = 0.0;
  for (const auto& t : gb->times) {
    fmt::print("gpu capture {:<10} {:10.3f} ms\n", t.name, t.milliseconds);
    gpuMs += t.milliseconds;
  }
  for (const auto& t : sampled->times) {
    fmt::print("gpu sampler {:<10} {:10.3f} ms (sum over rounds)\n", t.name, t.milliseconds);
    gpuMs += t.milliseconds;
  }
  fmt::print("gpu total {:.3f} ms of GPU time; wall {:.3f} s\n", gpuMs, gpuSeconds);
  if (!o.skipCpu)
    fmt::print("speedup (cpu wall / gpu wall, spacing pass excluded): {:.2f}x\n", cpuSeconds / gpuSeconds);
  printPrefixes(o.skipCpu ? nullptr : &cpuTexels, o.skipCpu ? nullptr : &cpuOrder, gb->texels, sampled->order);
}

} // namespace

void addBenchSurfelPointsCommand(CLI::App& bench) {
  auto* b = bench.add_subcommand("surfels-points",
                                 "Point-cloud surfels: exact CPU order vs GPU disc capture + sampler on one scan");
  auto o = std::make_shared<BenchPointsOptions>();
  b->add_option("input", o->input, "Point cloud PLY (no faces), e.g. from mirage gen points")->required();
  b->add_option("--count", o->count, "Surfels to sample")->capture_default_str();
  b->add_option("--resolution", o->resolution, "GPU path: G-buffer resolution per view")->capture_default_str();
  b->add_option("--views", o->views, "GPU path: capture directions")->capture_default_str();
  b->add_option("--threshold", o->threshold, "GPU sampler candidate threshold")->capture_default_str();
  b->add_flag("--skip-cpu", o->skipCpu, "Run the GPU path only (the exact CPU order is slow on huge scans)");
  b->add_option("--device", o->device, "Vulkan device name substring or index");
  b->callback([o] { runBenchPoints(*o); });
}

} // namespace mirage::cli
