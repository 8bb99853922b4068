// mirage bench surfels-sort: the GPU radix sort against the bitonic sort it replaced, on keys
// shaped like the surfel sampler's candidates (radius float bits << 32 | texel index).
// mirage bench surfels-sampler: the whole sampler per disc splatter (compute, mesh, geometry) on one
// G-buffer, per-stage GPU times.
#include <algorithm>
#include <bit>
#include <cstring>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/query.h"
#include "mirage/gpu/radix_sort.h"
#include "mirage/surfels/capture.h"
#include "render_common.h"
#include "surfel_disc_raster.h"

namespace mirage::cli {

namespace {

struct BenchSortOptions {
  std::vector<uint32_t> counts{10000, 100000, 1000000};
  uint32_t texels = 16u << 20; // index range of the low word: 1024² × 16 views
  int repeat = 5;
  std::string device;
  bool json = false;
};

uint32_t nextPow2(uint32_t v) {
  uint32_t p = 1;
  while (p < v) p <<= 1;
  return p;
}

std::vector<uint64_t> samplerLikeKeys(uint32_t n, uint32_t texels) {
  std::mt19937 rng(n);
  std::uniform_real_distribution<float> radius(0.001f, 0.01f);
  std::vector<uint64_t> keys(n);
  for (uint64_t& k : keys) {
    float r = radius(rng);
    uint32_t bits;
    std::memcpy(&bits, &r, 4);
    k = rng() % 3 == 0 ? 0 : uint64_t(bits) << 32 | (rng() % texels); // a third rejected (0)
  }
  return keys;
}

void runBenchSort(const BenchSortOptions& o) {
  if (o.repeat < 1 || o.repeat > 1000) return fail("--repeat must be in 1..1000");
  for (uint32_t n : o.counts)
    if (n == 0 || n > (1u << 26)) return fail("--counts must be in 1..67108864");
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  gpu::Context& c = **ctx;
  const uint32_t samplerDigits = gpu::digitMaskForIndexBelow(o.texels);
  nlohmann::json rows = nlohmann::json::array();
  if (!o.json)
    fmt::print("sort of sampler-like 64-bit keys on {} (median of {}), descending\n{:>9} {:>12} {:>12} {:>12} {:>8} "
               "{:>10}\n",
               c.caps().name, o.repeat, "keys", "radix ms", "radix64 ms", "bitonic ms", "speedup", "Mkeys/s");
  for (uint32_t n : o.counts) {
    std::vector<uint64_t> keys = samplerLikeKeys(n, o.texels);
    uint32_t padded = nextPow2(n);
    std::vector<uint64_t> paddedKeys = keys;
    paddedKeys.resize(padded, 0); // 0 sorts last in a descending sort
    VkBufferUsageFlags usage =
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    gpu::Buffer source = gpu::createBufferWithData<uint64_t>(c, paddedKeys, usage, "bench keys source");
    gpu::Buffer work = gpu::createBuffer(c, size_t(padded) * 8, usage, gpu::MemoryUsage::GpuOnly, "bench keys");
    gpu::RadixSort sorter(c, padded);
    gpu::GpuTimer timer(c, 4);
    std::vector<double> times[3];
    uint32_t dispatches[3] = {};
    std::vector<uint64_t> results[3];
    for (int run = -1; run < o.repeat; ++run) // run -1: untimed warm-up
      for (int method = 0; method < 3; ++method) {
        // barriers: the copy completes before the sort reads (cmdSort/cmdBitonicSort wait for
        // transfer writes); the submit waits before the readback.
        c.submitAndWait([&](VkCommandBuffer cmd) {
          timer.cmdReset(cmd);
          VkBufferCopy region{0, 0, size_t(padded) * 8};
          vkCmdCopyBuffer(cmd, source.handle(), work.handle(), 1, &region);
          uint32_t slot = timer.cmdBegin(cmd, "sort");
          if (method == 0) sorter.cmdSort(cmd, work, n, {true, samplerDigits});
          if (method == 1) sorter.cmdSort(cmd, work, n, {true, 0xFF});
          if (method == 2) sorter.cmdBitonicSort(cmd, work, padded, true);
          timer.cmdEnd(cmd, slot);
          dispatches[method] = sorter.lastDispatches();
        });
        if (run >= 0) times[method].push_back(timer.read().at(0).milliseconds);
        if (run == 0) {
          std::vector<uint8_t> bytes = gpu::readbackBuffer(c, work, size_t(n) * 8);
          results[method].resize(n);
          std::memcpy(results[method].data(), bytes.data(), bytes.size());
        }
      }
    std::vector<uint64_t> expected = keys;
    std::sort(expected.begin(), expected.end(), std::greater<>());
    bool same = results[0] == expected && results[1] == expected && results[2] == expected;
    double radix = median(times[0]), radix64 = median(times[1]), bitonic = median(times[2]);
    double speedup = bitonic / std::max(radix, 1e-9);
    if (o.json) {
      rows.push_back({{"keys", n},
                      {"radix_ms", radix},
                      {"radix64_ms", radix64},
                      {"bitonic_ms", bitonic},
                      {"speedup", speedup},
                      {"dispatches", {dispatches[0], dispatches[1], dispatches[2]}},
                      {"matches_std_sort", same}});
    } else {
      fmt::print("{:>9} {:>12.3f} {:>12.3f} {:>12.3f} {:>7.2f}x {:>10.1f}{}\n", n, radix, radix64, bitonic, speedup,
                 double(n) / (radix * 1e3), same ? "" : "  MISMATCH vs std::sort");
    }
    if (!same) return fail(fmt::format("GPU sort of {} keys differs from std::sort", n));
  }
  if (o.json)
    fmt::print("{}\n", nlohmann::json({{"bench", "surfels-sort"}, {"device", c.caps().name}, {"rows", rows}}).dump(2));
  else
    fmt::print("radix: {} digits of 8 bits (texel index < {}); radix64: all 8 digits; bitonic: padded to 2^k\n",
               std::popcount(samplerDigits), o.texels);
}

struct BenchSamplerOptions {
  std::string input;
  uint32_t count = 100000;
  uint32_t resolution = 1024;
  uint32_t views = 16;
  uint32_t layers = 1;
  float threshold = 0.75f;
  std::string discRaster = "all";
  int repeat = 3;
  std::string device;
  bool json = false;
};

void runBenchSampler(const BenchSamplerOptions& o) {
  auto rasters = parseDiscRasterList(o.discRaster);
  if (!rasters) return fail(rasters.error());
  if (o.repeat < 1 || o.repeat > 100) return fail("--repeat must be in 1..100");
  if (o.count == 0) return fail("--count must be at least 1");
  if (o.views == 0 || o.views > 256) return fail("--views must be in 1..256");
  if (o.layers == 0 || o.layers > 16) return fail("--layers must be in 1..16");
  if (o.resolution == 0) return fail("--resolution must be at least 1");
  if (!(o.threshold > 0.0f && o.threshold <= 1.0f)) return fail("--threshold must be in (0, 1]");
  auto scene = loadSceneArgument(o.input);
  if (!scene) return fail(scene.error());
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  gpu::Context& c = **ctx;
  surfels::CaptureConfig cc;
  cc.resolution = o.resolution;
  cc.views = o.views;
  cc.layers = o.layers;
  auto gb = surfels::captureGBuffer(c, *scene, cc);
  if (!gb) return fail(gb.error());
  surfels::GpuSamplerConfig sc;
  sc.count = o.count;
  sc.threshold = o.threshold;
  auto runs = compareDiscRasters(c, *gb, sc, *rasters, o.repeat);
  if (!runs) return fail(runs.error());
  if (o.json) {
    fmt::print("{}\n", nlohmann::json({{"bench", "surfels-sampler"},
                                       {"device", c.caps().name},
                                       {"input", o.input},
                                       {"texels", gb->texels.size()},
                                       {"count", o.count},
                                       {"resolution", o.resolution},
                                       {"views", o.views * o.layers},
                                       {"repeat", o.repeat},
                                       {"rows", discRasterJson(*runs)}})
                           .dump(2));
  } else {
    fmt::print("surfel sampler on {}: {} ({} texels, {} views x {}^2), {} surfels, median of {}\n", c.caps().name,
               o.input, gb->texels.size(), o.views * o.layers, o.resolution, o.count, o.repeat);
    printDiscRasterTable(*runs);
    for (const DiscRasterRun& r : *runs) {
      if (!r.skipped.empty()) continue;
      fmt::print("{:<10}", surfels::toString(r.raster));
      for (const gpu::PassTime& t : r.times) fmt::print(" {} {:.3f}", t.name, t.milliseconds);
      fmt::print(" ms; sampler wall {:.3f} s\n", r.seconds);
    }
  }
  for (const DiscRasterRun& r : *runs)
    if (r.skipped.empty() && !r.sameOrderAsFirst)
      return fail(fmt::format("--disc-raster {} gives another sample order than the first splatter",
                              surfels::toString(r.raster)));
}

} // namespace

void addBenchSurfelsSamplerCommand(CLI::App& bench) {
  auto* b = bench.add_subcommand("surfels-sampler",
                                 "Surfel sampler per disc splatter (compute, mesh, geometry) on one G-buffer");
  auto o = std::make_shared<BenchSamplerOptions>();
  b->add_option("input", o->input, "Scene file or gen:KIND[:SIZE[:SEED]]")->required();
  b->add_option("--count", o->count, "Surfels to sample")->capture_default_str();
  b->add_option("--resolution", o->resolution, "G-buffer resolution per view")->capture_default_str();
  b->add_option("--views", o->views, "Orthographic capture directions")->capture_default_str();
  b->add_option("--layers", o->layers, "Depth-peeling layers per view")->capture_default_str();
  b->add_option("--threshold", o->threshold, "Candidate threshold")->capture_default_str();
  b->add_option("--disc-raster", o->discRaster,
                "Splatters to time: all, or a comma list of compute, mesh, geometry, mesh-depth")
      ->capture_default_str();
  b->add_option("--repeat", o->repeat, "Timed runs per splatter; the median is reported")->capture_default_str();
  b->add_option("--device", o->device, "Vulkan device name substring or index");
  b->add_flag("--json", o->json, "Print results as JSON");
  b->callback([o] { runBenchSampler(*o); });
}

void addBenchSurfelsSortCommand(CLI::App& bench) {
  auto* b = bench.add_subcommand("surfels-sort", "GPU radix sort vs the bitonic baseline on surfel-sampler keys");
  auto o = std::make_shared<BenchSortOptions>();
  b->add_option("--counts", o->counts, "Key counts to sort")->delimiter(',')->capture_default_str();
  b->add_option("--texels", o->texels, "Texel index range of the keys' low word")->capture_default_str();
  b->add_option("--repeat", o->repeat, "Timed runs per method; the median is reported")->capture_default_str();
  b->add_option("--device", o->device, "Vulkan device name substring or index");
  b->add_flag("--json", o->json, "Print results as JSON");
  b->callback([o] { runBenchSort(*o); });
}

} // namespace mirage::cli
