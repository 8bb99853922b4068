// mirage bench rays: ray throughput of the ray backends on one set of random rays (origins in the
// view cells or the scene box, uniform directions), with every hit recorded into a triangle set as
// GVS++ does. Vulkan reports the trace dispatch alone (timestamp queries) and the wall time with
// upload and readback (24-byte rays, as GVS++ rays go; the default compute variant also with
// 32-byte ones); its "generated" mode makes the rays on the device, and the compute traversal's
// "staged" mode traces the same rays from device-local copies (copies timed apart).
// Both Vulkan traversals (the ray-tracing pipeline and the compute shader: plain, with persistent
// threads, with its stack in shared memory, over 4-wide and compressed 8-wide nodes) trace the same
// rays in one run, and their GPU-time ratios are printed, so one run decides the default.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/visibility/view_cell.h"
#include "mirage/visibility/vulkan_backend.h"
#include "ray_backend_choice.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct BenchRaysOptions {
  std::string input, cells, backend = "all", geometry = "auto", device;
  uint64_t rays = 4'000'000;
  int repeat = 3;
  bool json = false;
  bool spatialSplits = false;
  uint32_t leafSize = 4;
  uint64_t work = 0; // rays counted by the CPU replica of the traversal (0: none)
};

// Random numbers from the ray index alone (PCG hash), so any slice of rays can be made anywhere.
uint32_t pcg(uint32_t v) {
  uint32_t state = v * 747796405u + 2891336453u;
  uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
float unit(uint32_t v) { return float(v >> 8) * (1.0f / 16777216.0f); }

// The stream key of the host-made rays; the shader's generated rays (generatedRay in
// vis_trace_common.glsl) are the same map with key pcg(seed).
constexpr uint32_t kHostRayKey = 0x2545f491u;

std::vector<vis::Ray> randomRays(const Bounds& box, uint64_t count, uint32_t key = kHostRayKey) {
  std::vector<vis::Ray> rays(count);
  for (uint64_t i = 0; i < count; ++i) {
    uint32_t h = pcg(uint32_t(i) ^ key), h1 = pcg(h), h2 = pcg(h1), h3 = pcg(h2), h4 = pcg(h3);
    vis::Ray& r = rays[i];
    r.origin = glm::mix(box.min, box.max, glm::vec3(unit(h), unit(h1), unit(h2)));
    float z = 1.0f - 2.0f * unit(h3), s = std::sqrt(std::max(0.0f, 1.0f - z * z));
    float phi = 6.2831853f * unit(h4);
    r.dir = {s * std::cos(phi), s * std::sin(phi), z};
  }
  return rays;
}

// Rays whose closest triangle differs from Embree's but lies at the same depth (a shared edge or
// a coplanar duplicate), to tell tie-breaking from wrong hits.
size_t tiedHits(const std::vector<vis::Hit>& a, const std::vector<vis::Hit>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i)
    n += a[i].triangle != b[i].triangle && a[i].triangle != vis::kNoHit && b[i].triangle != vis::kNoHit &&
         std::abs(a[i].t - b[i].t) <= 1e-3f * std::max(1.0f, b[i].t);
  return n;
}

void runBenchRays(const BenchRaysOptions& o) {
  if (o.backend != "all" && o.backend != "embree" && o.backend != "vulkan" && o.backend != "compute")
    return fail("--backend must be embree, vulkan, compute or all");
  if (o.rays == 0 || o.rays > (uint64_t(1) << 31)) return fail("--rays must be in 1..2^31");
  if (o.repeat < 1) return fail("--repeat must be at least 1");
  if (o.leafSize < 1 || o.leafSize > 32) return fail("--leaf-size must be in 1..32");
  if (auto s = checkRayBackendChoice({.backend = "auto", .geometry = o.geometry}); !s) return fail(s.error());
  std::vector<vis::ViewCell> cells;
  if (!o.cells.empty()) {
    auto c = vis::loadViewCells(o.cells);
    if (!c) return fail(c.error());
    cells = std::move(*c);
  }
  auto scene = loadSceneArgument(o.input);
  if (!scene) return fail(scene.error());
  Bounds box;
  if (cells.empty()) box = scene->worldBounds();
  for (const vis::ViewCell& cell : cells)
    for (glm::vec3 p : cell.corners()) box.add(p);
  if (box.empty()) return fail(o.input + ": empty scene");
  std::vector<vis::Ray> rays = randomRays(box, o.rays);
  std::vector<vis::Hit> reference, hits(rays.size());
  nlohmann::json results = nlohmann::json::array(), speedups = nlohmann::json::array(), work = nlohmann::json::array();
  if (o.work > 0) {
    // The same traversal on the host-made rays and on the rays the shader generates (seed 1, as
    // traceGenerated below): equal work per ray means the rate gap between the two modes comes
    // from moving rays and hits, not from the rays themselves.
    const uint64_t n = std::min(o.work, o.rays);
    const std::vector<vis::Ray> host(rays.begin(), rays.begin() + std::ptrdiff_t(n));
    const std::vector<vis::Ray> generated = randomRays(box, n, pcg(1u));
    for (uint32_t width : {4u, 8u})
      for (int g = 0; g < 2; ++g) {
        auto w = vis::countTraversalWork(*scene, g ? generated : host, width);
        if (!w) return fail(w.error());
        work.push_back({{"bvh_width", width},
                        {"rays", g ? "generated" : "host"},
                        {"counted", n},
                        {"nodes_per_ray", w->nodes},
                        {"triangle_tests_per_ray", w->triangleTests},
                        {"hit_fraction", w->hitFraction}});
        if (!o.json)
          fmt::print("CPU replica, {}-wide BVH, {:9} rays ({}): {:6.2f} nodes and {:6.2f} triangle tests per ray, "
                     "{:.2f}% hit\n",
                     width, g ? "generated" : "host", n, w->nodes, w->triangleTests, 100.0 * w->hitFraction);
      }
  }
  auto report = [&](const std::string& name, double wallMs, double gpuMs, size_t found, double agree) {
    nlohmann::json j{{"backend", name},
                     {"rays", o.rays},
                     {"wall_ms", wallMs},
                     {"wall_mrays_per_s", double(o.rays) / wallMs * 1e-3},
                     {"triangles_found", found}};
    if (gpuMs > 0) {
      j["gpu_ms"] = gpuMs;
      j["gpu_mrays_per_s"] = double(o.rays) / gpuMs * 1e-3;
    }
    if (agree >= 0) j["same_hit_as_embree"] = agree;
    results.push_back(j);
    if (o.json) return;
    fmt::print("{:18} wall {:9.2f} ms {:9.2f} Mrays/s", name, wallMs, double(o.rays) / wallMs * 1e-3);
    if (gpuMs > 0) fmt::print(" | GPU trace {:9.3f} ms {:10.2f} Mrays/s", gpuMs, double(o.rays) / gpuMs * 1e-3);
    fmt::print(" | {} triangles hit", found);
    if (agree >= 0) fmt::print(" | same hit as Embree {:.4f}%", agree * 100.0);
    fmt::print("\n");
  };

  std::string geometry = o.geometry;
  if (o.backend != "vulkan") {
    auto b = openNamedRayBackend("embree", geometry, true, *scene, nullptr);
    if (!b) return fail(b.error());
    std::vector<double> wall;
    size_t found = 0;
    for (int r = 0; r < o.repeat; ++r) {
      vis::TriangleSet record((*b)->triangleCount());
      auto t0 = std::chrono::steady_clock::now();
      (*b)->trace(rays, hits, {.record = &record});
      wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      found = record.count();
    }
    reference = hits;
    report(std::string((*b)->name()), median(wall), 0.0, found, -1.0);
  }
  if (o.backend != "embree") {
    auto ctx = openDevice(o.device);
    if (!ctx) return fail(ctx.error());
    struct Variant {
      std::string label;
      vis::VulkanRayOptions::Traversal traversal;
      ComputeVariant compute{};
      double traceGpu = 0.0, generatedGpu = 0.0; // medians, milliseconds
    };
    using T = vis::VulkanRayOptions::Traversal;
    std::vector<Variant> variants;
    if (o.backend != "compute") {
      if ((*ctx)->caps().rayTracingPipeline)
        variants.push_back({"pipeline", T::Pipeline});
      else if (o.backend == "vulkan")
        return fail(
            fmt::format("vulkan: {} has no ray-tracing pipeline (VK_KHR_ray_tracing_pipeline)", (*ctx)->caps().name));
    }
    if (o.backend != "vulkan")
      for (const ComputeVariant& c : kComputeVariants) variants.push_back({c.name, T::Compute, c});
    for (Variant& v : variants) {
      vis::VulkanRayOptions vo;
      vo.geometry = geometry == "flatten"    ? vis::VulkanRayOptions::Geometry::Flatten
                    : geometry == "instance" ? vis::VulkanRayOptions::Geometry::Instance
                                             : vis::VulkanRayOptions::Geometry::Auto;
      vo.traversal = v.traversal;
      vo.persistentThreads = v.compute.persistentThreads;
      vo.sharedStack = v.compute.sharedStack;
      vo.bvhWidth = v.traversal == T::Compute ? v.compute.bvhWidth : 2;
      vo.postponeTriangles = v.compute.postponeTriangles;
      vo.spatialSplits = o.spatialSplits;
      vo.bvhLeafSize = o.leafSize;
      vo.batchRays = size_t(o.rays); // one launch: what the dispatch alone can do
      auto b = vis::createVulkanBackend(**ctx, *scene, vo);
      if (!b) return fail(b.error());
      vis::RayBvhStats bvh = (*b)->bvhStats();
      if (!o.json) {
        fmt::print("{} ({}) on {}: {} triangles, build {:.2f} s", o.input, v.label, (*ctx)->caps().name,
                   (*b)->triangleCount(), (*b)->buildSeconds());
        if (bvh.nodes > 0)
          fmt::print(" (BVH on the host {:.2f} s: {} nodes, {} leaf triangles, depth {})", bvh.buildSeconds, bvh.nodes,
                     bvh.triangleRefs, bvh.depth);
        fmt::print("\n");
      }
      std::vector<double> wall, gpu, genWall, genGpu, stagedWall, stagedGpu, stagedCopy, fullWall, fullGpu;
      size_t found = 0, genFound = 0, stagedFound = 0, fullFound = 0;
      double stagedBytes = 0.0;
      const bool staging = v.traversal == T::Compute;
      // The default compute variant also with 32-byte rays (the others send 24-byte ones: the rays
      // here have the interval [0, inf)), to show what the bytes per ray cost across PCIe.
      const bool fullRays = v.label == kComputeVariants[0].name;
      std::vector<vis::Hit> stagedHits(staging ? rays.size() : 0);
      for (int r = 0; r < o.repeat; ++r) {
        vis::TriangleSet record((*b)->triangleCount());
        auto t0 = std::chrono::steady_clock::now();
        (*b)->trace(rays, hits, {.record = &record});
        wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        gpu.push_back((*b)->lastTiming().gpuMilliseconds);
        found = record.count();
        if (fullRays) {
          vis::TriangleSet fullRecord((*b)->triangleCount());
          (*b)->setCompactRays(false);
          t0 = std::chrono::steady_clock::now();
          (*b)->trace(rays, stagedHits, {.record = &fullRecord});
          fullWall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          (*b)->setCompactRays(true);
          fullGpu.push_back((*b)->lastTiming().gpuMilliseconds);
          fullFound = fullRecord.count();
        }
        if (staging) { // the same rays through device-local copies: the trace alone, then the copies
          vis::TriangleSet stagedRecord((*b)->triangleCount());
          (*b)->setStagedRays(true);
          t0 = std::chrono::steady_clock::now();
          (*b)->trace(rays, stagedHits, {.record = &stagedRecord});
          stagedWall.push_back(
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          (*b)->setStagedRays(false);
          stagedGpu.push_back((*b)->lastTiming().gpuMilliseconds);
          stagedCopy.push_back((*b)->lastTiming().copyMilliseconds);
          stagedBytes = (*b)->lastTiming().copyBytes;
          stagedFound = stagedRecord.count();
        }
        vis::TriangleSet generated((*b)->triangleCount());
        t0 = std::chrono::steady_clock::now();
        (*b)->traceGenerated(box.min, box.max, o.rays, 1, &generated);
        genWall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        genGpu.push_back((*b)->lastTiming().gpuMilliseconds);
        genFound = generated.count();
      }
      double agree = -1.0, tied = -1.0;
      if (!reference.empty()) {
        size_t same = 0;
        for (size_t i = 0; i < hits.size(); ++i) same += hits[i].triangle == reference[i].triangle;
        agree = double(same) / double(hits.size());
        tied = double(same + tiedHits(hits, reference)) / double(hits.size());
      }
      std::string name((*b)->name());
      report(name, median(wall), median(gpu), found, agree);
      results.back()["traversal"] = v.label;
      if (tied >= 0) {
        results.back()["same_or_tied_with_embree"] = tied;
        if (!o.json)
          fmt::print("{:18} same closest triangle as Embree or another at the same depth: {:.4f}%\n", "", tied * 100.0);
      }
      if (fullRays) {
        report(name + " 32B rays", median(fullWall), median(fullGpu), fullFound, -1.0);
        results.back()["traversal"] = v.label;
      }
      if (staging) {
        size_t same = 0;
        for (size_t i = 0; i < hits.size(); ++i)
          same += stagedHits[i].triangle == hits[i].triangle && stagedHits[i].t == hits[i].t;
        report(name + " staged", median(stagedWall), median(stagedGpu), stagedFound, -1.0);
        results.back()["traversal"] = v.label;
        results.back()["copy_ms"] = median(stagedCopy);
        results.back()["copy_bytes"] = stagedBytes;
        results.back()["same_hits_as_unstaged"] = double(same) / double(hits.size());
        if (!o.json)
          fmt::print("{:18} staged: rays and hits copied in {:.3f} ms of GPU time around the trace "
                     "({:.2f} GB/s); {:.4f}% the same hits as the unstaged trace\n",
                     "", median(stagedCopy), stagedBytes / (median(stagedCopy) * 1e6),
                     100.0 * double(same) / double(hits.size()));
      }
      report(name + " generated", median(genWall), median(genGpu), genFound, -1.0);
      results.back()["traversal"] = v.label;
      v.traceGpu = median(gpu);
      v.generatedGpu = median(genGpu);
    }
    // GPU-time speedups over the first variant (the pipeline when the device has one).
    for (size_t i = 1; i < variants.size(); ++i) {
      const Variant &base = variants[0], &v = variants[i];
      if (base.traceGpu <= 0 || v.traceGpu <= 0 || v.generatedGpu <= 0) continue;
      double trace = base.traceGpu / v.traceGpu, generated = base.generatedGpu / v.generatedGpu;
      speedups.push_back(
          {{"variant", v.label}, {"baseline", base.label}, {"trace_speedup", trace}, {"generated_speedup", generated}});
      if (!o.json)
        fmt::print("{} vs {}: {:.2f}x the GPU ray rate on the same rays, {:.2f}x on generated rays\n", v.label,
                   base.label, trace, generated);
    }
  }
  if (o.json)
    fmt::print("{}\n",
               nlohmann::json{
                   {"input", o.input}, {"rays", o.rays}, {"results", results}, {"speedups", speedups}, {"work", work}}
                   .dump(2));
}

} // namespace

void addBenchRaysCommand(CLI::App* bench) {
  auto* br = bench->add_subcommand("rays", "Ray throughput per backend: random rays, hits recorded as GVS++ does");
  auto o = std::make_shared<BenchRaysOptions>();
  br->add_option("input", o->input, "Scene file or gen:KIND[:SIZE[:SEED]]")->required();
  br->add_option("--backend", o->backend,
                 "embree, vulkan (ray-tracing pipeline), compute (every compute traversal variant) or all")
      ->capture_default_str();
  br->add_option("--rays", o->rays, "Rays per run")->capture_default_str();
  br->add_option("--cells", o->cells, "Ray origins in these view cells' box (default: the scene box)");
  br->add_option("--geometry", o->geometry, "auto, flatten or instance")->capture_default_str();
  br->add_option("--repeat", o->repeat, "Runs; the median is reported")->capture_default_str();
  br->add_option("--device", o->device, "Vulkan device name substring or index");
  br->add_flag("--json", o->json, "Print results as JSON");
  br->add_option("--leaf-size", o->leafSize, "Compute traversal: most triangles per BVH leaf (1..32)")
      ->capture_default_str();
  br->add_flag("--spatial-splits", o->spatialSplits, "Compute traversal: BVH with spatial splits (slower build)");
  br->add_option("--work", o->work,
                 "Count nodes and triangle tests per ray with a CPU replica of the 4- and 8-wide traversals on "
                 "this many host-made and shader-generated rays");
  br->callback([o] { runBenchRays(*o); });
}

} // namespace mirage::cli
