// mirage surfels INPUT -o out.ply|out.mrg: progressive blue-noise surfels of a scene or a point cloud;
// --per-mesh: one cloud per mesh, spread over the ranks under mpirun (docs/bake.md).
#include <chrono>
#include <cstdio>
#include <span>

#include <fmt/format.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/asset/container.h"
#include "mirage/bake/surfel_bake.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "render_common.h"
#include "surfel_disc_raster.h"

namespace mirage::cli {

namespace {

struct SurfelsOptions {
  std::string input;
  std::string output;
  std::string device;
  uint32_t count = 100000;
  uint32_t resolution = 1024;
  uint32_t views = 16;
  uint32_t layers = 1;
  float threshold = 0.75f;
  bool reference = false;
  bool perMesh = false;
  bool resume = false; // --per-mesh: continue from the journal beside the output
  bool append = false; // add the SURF chunks to the existing .mrg at -o (its other chunks kept)
  bool bitonicSort = false;
  OutputFlags flags;                  // --quiet (errors only), --progress (log lines)
  std::string discRaster = "compute"; // one splatter, a comma list or all (timed side by side)
  std::vector<surfels::DiscRaster> discRasters;
  std::string points = "auto";       // point clouds: "cpu" (exact order), "gpu" (disc capture + GPU sampler), "auto"
  std::string blocks = "1024:16384"; // --surfel-blocks FIRST:MAX, surfels per SURF block (.mrg)
  surfels::SurfelBlockConfig blockConfig;
};

// One sampled cloud with what the report prints about it.
struct Sampled {
  surfels::GBufferTexels texels;
  surfels::SampleOrder order;
  surfels::SampleOrder reference; // empty without --reference
  uint32_t passes = 0, rounds = 0;
  double captureSeconds = 0.0, samplerSeconds = 0.0, referenceSeconds = 0.0;
  std::vector<gpu::PassTime> gpuTimes, samplerTimes;
  std::vector<DiscRasterRun> discRuns; // several --disc-raster splatters: each one's run
};

// Point clouds on the CPU: the exact farthest-point order over the points themselves (no capture,
// no GPU; the k-NN spacing pass is counted as the capture).
Sampled samplePointsExactly(const surfels::ScanPoints& points, double spacingSeconds, const SurfelsOptions& o) {
  Sampled s;
  auto t0 = std::chrono::steady_clock::now();
  s.texels = surfels::pointCloudTexels(points);
  s.captureSeconds = spacingSeconds + secondsSince(t0);
  t0 = std::chrono::steady_clock::now();
  s.order = surfels::farthestPointReference(s.texels, o.count);
  s.samplerSeconds = secondsSince(t0);
  return s;
}

// Meshes (scene) or point clouds on the GPU (points: the discs' capture): G-buffer capture, then
// the GPU sampler.
Result<Sampled> sampleScene(gpu::Context* ctx, const Scene& scene, const SurfelsOptions& o,
                            const surfels::ScanPoints* points = nullptr, double spacingSeconds = 0.0) {
  Sampled s;
  auto t0 = std::chrono::steady_clock::now();
  surfels::CaptureConfig cc;
  cc.resolution = o.resolution;
  cc.views = o.views;
  cc.layers = o.layers;
  auto gb = points ? surfels::capturePointCloud(*ctx, *points, cc) : surfels::captureGBuffer(*ctx, scene, cc);
  if (!gb) return gb.error();
  s.captureSeconds = spacingSeconds + secondsSince(t0);
  s.passes = gb->passes;
  s.gpuTimes = gb->times;
  surfels::GpuSamplerConfig sc;
  sc.count = o.count;
  sc.threshold = o.threshold;
  sc.bitonicSort = o.bitonicSort;
  sc.discRaster = o.discRasters[0];
  // The sampler reports samples so far of the count after every round.
  Progress progress(o.flags.progressMode());
  progress.begin("sampling", sc.count);
  if (progress.mode() != ProgressMode::None)
    sc.progress = [&progress](uint32_t samples, uint32_t count, uint32_t rounds) {
      progress.update(samples, count, fmt::format("{} surfels, round {}", samples, rounds));
    };
  if (o.discRasters.size() > 1) {
    auto runs = compareDiscRasters(*ctx, *gb, sc, o.discRasters, 1);
    if (!runs) return runs.error();
    s.discRuns = std::move(*runs);
    const DiscRasterRun* first = nullptr; // the output comes from the first splatter that ran here
    for (const DiscRasterRun& r : s.discRuns) {
      if (!r.skipped.empty()) continue;
      if (!first) first = &r;
      if (!r.sameOrderAsFirst)
        return Error{fmt::format("surfels: internal error: --disc-raster {} gives another order than {}",
                                 surfels::toString(r.raster), surfels::toString(first->raster))};
    }
    if (!first) return Error{"surfels: none of the --disc-raster splatters runs on " + ctx->caps().name};
    s.order = first->order;
    s.rounds = first->rounds;
    s.samplerSeconds = first->seconds;
    s.samplerTimes = first->times;
  } else {
    auto sampled = surfels::sampleOnGpu(*ctx, *gb, sc);
    if (!sampled) return sampled.error();
    s.order = std::move(sampled->order);
    s.rounds = sampled->rounds;
    s.samplerSeconds = sampled->seconds;
    s.samplerTimes = sampled->times;
  }
  progress.end();
  s.texels = std::move(gb->texels);
  if (o.reference) {
    t0 = std::chrono::steady_clock::now();
    s.reference = surfels::farthestPointReference(s.texels, o.count);
    s.referenceSeconds = secondsSince(t0);
  }
  return s;
}

void printReport(const Sampled& s, const surfels::SurfelCloud& cloud, bool reference) {
  const surfels::GBufferTexels& texels = s.texels;
  fmt::print("sampled area A = {:.6g} (texel size {:.4g}); N_ref {} mean spacing {:.4g} median {:.4g}\n",
             texels.totalArea, texels.texelSize, cloud.referenceCount, cloud.referenceMeanSpacing,
             cloud.referenceMedianSpacing);
  fmt::print("capture {:.3f} s (with readback and areas), sampler {:.3f} s in {} rounds", s.captureSeconds,
             s.samplerSeconds, s.rounds);
  if (reference) fmt::print(", CPU reference {:.3f} s", s.referenceSeconds);
  fmt::print("\n");
  for (const auto& t : s.gpuTimes) fmt::print("gpu {:<10} {:10.3f} ms\n", t.name, t.milliseconds);
  for (const auto& t : s.samplerTimes) fmt::print("gpu {:<10} {:10.3f} ms (sum over rounds)\n", t.name, t.milliseconds);
  fmt::print("{:>8} {:>10} {:>7} {:>9}{}\n", "prefix", "radius", "rho", "coverage",
             reference ? "   ref rho ref coverage" : "");
  std::vector<uint32_t> prefixes;
  for (uint32_t n : {1000u, 10000u, 100000u, 1000000u})
    if (n < cloud.size()) prefixes.push_back(n);
  prefixes.push_back(uint32_t(cloud.size()));
  for (uint32_t n : prefixes) {
    if (n == 0) continue;
    surfels::PrefixQuality q = surfels::measurePrefix(texels, s.order, n);
    fmt::print("{:>8} {:>10.4g} {:>7.3f} {:>9.4f}", n, q.radius, q.rho, q.coverage);
    if (reference) {
      surfels::PrefixQuality r = surfels::measurePrefix(texels, s.reference, n);
      fmt::print(" {:>9.3f} {:>12.4f}", r.rho, r.coverage);
    }
    fmt::print("\n");
  }
}

// --per-mesh: one unit per mesh, spread over the ranks under mpirun (docs/bake.md). Every rank runs
// this; the import on rank 0, each rank samples on its own device, rank 0 writes and prints.
void runSurfelsPerMesh(const SurfelsOptions& o) {
  auto world = bake::World::join();
  if (!world) return fail(world.error());
  auto failAll = [&](const Error& e) { return world->root() ? fail(e) : setExitCode(2); };
  auto t0 = std::chrono::steady_clock::now();
  Result<Scene> scene = Scene{};
  Status loaded = [&]() -> Status {
    if (!world->root()) return Ok{}; // rank 0 sends each rank the meshes it samples
    if (o.append)
      if (auto r = asset::AssetReader::open(o.output); !r) return r.error();
    io::ImportOptions importOptions;
    importOptions.allowPointClouds = true;
    scene = loadSceneArgument(o.input, importOptions);
    if (!scene) return scene.error();
    if (surfels::isPointCloud(*scene)) return Error{o.input + ": --per-mesh needs a mesh scene, not a point cloud"};
    return Ok{};
  }();
  if (Status all = world->agree(loaded); !all) return failAll(all.error());
  double importSeconds = secondsSince(t0);
  auto ctx = openDevice(o.device.empty() ? bake::deviceForRank(*world) : o.device);
  Status opened = ctx ? Status(Ok{}) : Status(ctx.error());
  if (ctx)
    if (std::string why = surfels::discRasterUnsupported(**ctx, o.discRasters[0]); !why.empty()) opened = Error{why};
  if (Status all = world->agree(opened); !all) return failAll(all.error());
  bool say = !o.flags.quiet && world->root();
  if (say) fmt::print("import {:.3f} s\n", importSeconds);

  bake::SurfelBakeConfig config;
  config.capture.resolution = o.resolution;
  config.capture.views = o.views;
  config.capture.layers = o.layers;
  config.sampler.count = o.count;
  config.sampler.threshold = o.threshold;
  config.sampler.bitonicSort = o.bitonicSort;
  config.sampler.discRaster = o.discRasters[0];
  Progress progress(world->root() ? o.flags.progressMode() : ProgressMode::None);
  bool begun = false;
  auto onUnit = [&](size_t done, size_t count, uint64_t, uint64_t) {
    if (!begun) progress.begin("sampling meshes", count), begun = true;
    progress.update(done, count, fmt::format("mesh {}/{}", done, count));
  };
  bake::BakeRun run{bake::journalPath(o.output), o.resume};
  bake::ScheduleReport report;
  auto t1 = std::chrono::steady_clock::now();
  auto baked = bake::bakeSurfelsPerMesh(*world, **ctx, *scene, config, run, &report, onUnit);
  if (begun) progress.end();
  if (!baked) return failAll(baked.error());
  double bakeSeconds = secondsSince(t1);
  Status written = Ok{};
  if (world->root()) {
    std::vector<surfels::MeshSurfels> clouds;
    for (const bake::MeshCloud& c : *baked) clouds.push_back(c.surfels);
    written = o.append ? surfels::appendSurfelMrg(o.output, clouds, o.blockConfig)
                       : surfels::writeSurfelMrg(o.output, clouds, o.blockConfig);
  }
  if (Status all = world->agree(written); !all) return failAll(all.error());
  bake::removeJournal(*world, {.journal = run.journal});
  if (!say) return;
  for (const bake::MeshCloud& c : *baked) {
    uint32_t i = c.surfels.mesh;
    fmt::print("mesh {:>4} {:<24} {:>8} surfels from {:>9} texels, rho {:.3f}, coverage {:.4f}, {:.3f} s\n", i,
               scene->meshes[i].name.substr(0, 24), c.surfels.cloud.size(), c.texels, c.rho, c.coverage, c.seconds);
  }
  std::string ranks;
  for (size_t r = 0; r < report.ranks.size() && world->size() > 1; ++r)
    ranks += fmt::format("{}rank {}: {} meshes", r ? ", " : " (", r, report.ranks[r].units.size());
  if (!ranks.empty()) ranks += ")";
  std::string resumed = report.resumedUnits ? fmt::format(", {} resumed", report.resumedUnits) : "";
  fmt::print("surfels {} -> {}: {} SURF chunks (one per mesh, object space) on {} in {:.2f} s on {} rank(s){}{}\n",
             o.input, o.output, baked->size(), (*ctx)->caps().name, bakeSeconds, world->size(), ranks, resumed);
}

void runSurfels(SurfelsOptions o) {
  // Everything cheap first, so bad input fails before the import and the GPU start.
  if (auto s = checkOutputPath(o.output, {".ply", ".mrg"}); !s) return fail(s.error());
  if (o.count == 0) return fail("--count must be at least 1");
  if (o.views == 0 || o.views > 256) return fail("--views must be in 1..256");
  if (o.layers == 0 || o.layers > 16) return fail("--layers must be in 1..16");
  if (o.resolution == 0) return fail("--resolution must be at least 1");
  if (!(o.threshold > 0.0f && o.threshold <= 1.0f)) return fail("--threshold must be in (0, 1]");
  auto rasters = parseDiscRasterList(o.discRaster);
  if (!rasters) return fail(rasters.error());
  o.discRasters = *rasters;
  if (rasters->size() > 1 && o.perMesh)
    return fail("--disc-raster " + o.discRaster + " times several splatters: give one with --per-mesh");
  if (o.perMesh && !o.output.ends_with(".mrg"))
    return fail("--per-mesh writes one SURF chunk per mesh: use a .mrg output");
  if (o.append && !o.perMesh)
    return fail("--append adds per-mesh SURF chunks to a baked .mrg: give --per-mesh (mirage build INPUT -o A.mrg; "
                "mirage surfels INPUT --per-mesh --append -o A.mrg)");
  if (o.resume && !o.perMesh) return fail("--resume continues a --per-mesh bake (docs/bake.md)");
  if (o.points != "auto" && o.points != "cpu" && o.points != "gpu")
    return fail(fmt::format("--points must be auto, cpu or gpu (got '{}')", o.points));
  auto blocks = surfels::parseSurfelBlockConfig(o.blocks);
  if (!blocks) return fail("--surfel-blocks: " + blocks.error().message);
  o.blockConfig = *blocks;
  if (o.perMesh) return runSurfelsPerMesh(o);
  if (o.append) {
    if (auto r = asset::AssetReader::open(o.output); !r) return fail(r.error());
  }

  auto t0 = std::chrono::steady_clock::now();
  io::ImportOptions importOptions;
  importOptions.allowPointClouds = true; // a PLY without faces is a scan to sample directly
  auto scene = loadSceneArgument(o.input, importOptions);
  if (!scene) return fail(scene.error());
  double importSeconds = secondsSince(t0);
  bool pointCloud = surfels::isPointCloud(*scene);
  // Point clouds: the spacing pass first (both paths need it), then the path (--points).
  surfels::ScanPoints points;
  double spacingSeconds = 0.0;
  bool pointsOnGpu = false;
  if (pointCloud) {
    t0 = std::chrono::steady_clock::now();
    auto scanned = surfels::scanPoints(*scene);
    if (!scanned) return fail(scanned.error());
    points = std::move(*scanned);
    spacingSeconds = secondsSince(t0);
    // auto: depth peeling of discs needs the scan's own normals; the exact path has no layers to peel.
    pointsOnGpu = o.points == "gpu" || (o.points == "auto" && (o.layers == 1 || points.hasNormals) &&
                                        points.size() >= surfels::kAutoGpuPointCount);
  }
  std::unique_ptr<gpu::Context> ctx;
  if (!pointCloud || pointsOnGpu) {
    auto opened = openDevice(o.device);
    if (opened && pointCloud && !(*opened)->caps().int64BufferAtomics)
      opened = Error{fmt::format("{} has no 64-bit buffer atomics", (*opened)->caps().name)};
    if (!opened && pointCloud && o.points == "auto") {
      if (!o.flags.quiet) fmt::print("no usable GPU ({}): the exact CPU path\n", opened.error().message);
      pointsOnGpu = false;
    } else if (!opened) {
      return fail(opened.error());
    } else {
      ctx = std::move(*opened);
    }
  }
  if (ctx && rasters->size() == 1)
    if (std::string why = surfels::discRasterUnsupported(*ctx, (*rasters)[0]); !why.empty()) return fail(why);
  std::string device = !pointCloud   ? ctx->caps().name
                       : pointsOnGpu ? ctx->caps().name + " (point cloud: disc capture + GPU sampler)"
                                     : std::string("the CPU (point cloud: exact farthest-point order)");
  bool say = !o.flags.quiet; // --quiet: nothing but errors
  if (say) fmt::print("import {:.3f} s\n", importSeconds);

  auto sampled = !pointCloud   ? sampleScene(ctx.get(), *scene, o)
                 : pointsOnGpu ? sampleScene(ctx.get(), *scene, o, &points, spacingSeconds)
                               : Result<Sampled>(samplePointsExactly(points, spacingSeconds, o));
  if (!sampled) return fail(sampled.error());
  surfels::SurfelCloud cloud = surfels::buildSurfelCloud(sampled->texels, sampled->order);
  Status written = o.output.ends_with(".mrg") ? surfels::writeSurfelMrg(o.output, cloud, o.blockConfig)
                                              : surfels::writeSurfelPly(o.output, cloud);
  if (!written) return fail(written.error());
  if (!say) return;
  if (pointCloud && !pointsOnGpu)
    fmt::print("surfels {} -> {}: {} surfels from {} points on {}\n", o.input, o.output, cloud.size(),
               sampled->texels.size(), device);
  else if (pointCloud)
    fmt::print("surfels {} -> {}: {} surfels from {} points via {} texels ({} views x {} layer(s) x {}^2) on {}\n",
               o.input, o.output, cloud.size(), points.size(), sampled->texels.size(), o.views, o.layers, o.resolution,
               device);
  else
    fmt::print("surfels {} -> {}: {} surfels from {} texels ({} views x {} layer(s) x {}^2, {} render pass(es)) on "
               "{}\n",
               o.input, o.output, cloud.size(), sampled->texels.size(), o.views, o.layers, o.resolution,
               sampled->passes, device);
  printReport(*sampled, cloud, o.reference && (!pointCloud || pointsOnGpu));
  if (!sampled->discRuns.empty()) {
    fmt::print("disc splatters on the same G-buffer (GPU times summed over rounds):\n");
    printDiscRasterTable(sampled->discRuns);
  }
}

} // namespace

void addSurfelsCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("surfels", "Sample progressive blue-noise surfels of a scene (PLY or .mrg)");
  auto o = std::make_shared<SurfelsOptions>();
  cmd->add_option("input", o->input,
                  "Scene file (.gltf .glb .obj .ply; a PLY without faces is a point cloud) or gen:KIND[:SIZE[:SEED]]")
      ->required();
  cmd->add_option("-o,--output", o->output, "Output .ply (x y z nx ny nz red green blue alpha radius) or .mrg")
      ->required();
  cmd->add_option("--count", o->count, "Surfels to sample")->capture_default_str();
  cmd->add_option("--resolution", o->resolution, "G-buffer resolution per view")->capture_default_str();
  cmd->add_option("--views", o->views, "Orthographic capture directions (Fibonacci sphere)")->capture_default_str();
  cmd->add_option("--threshold", o->threshold, "Candidate threshold relative to the round's largest radius")
      ->capture_default_str();
  cmd->add_option("--layers", o->layers, "Depth-peeling layers per view (occluded interior surfaces)")
      ->capture_default_str();
  cmd->add_flag("--reference", o->reference, "Also run the exact CPU farthest-point reference and compare");
  cmd->add_flag(
      "--append", o->append,
      "--per-mesh: add the SURF chunks to the existing .mrg at -o (e.g. from mirage build), keeping its DAGs");
  cmd->add_flag("--per-mesh", o->perMesh,
                "One cloud per mesh in object space (one SURF chunk each; .mrg only); under mpirun the meshes are "
                "spread over the ranks, one GPU per local rank (docs/bake.md)");
  cmd->add_flag("--resume", o->resume,
                "--per-mesh: continue a bake that died from OUTPUT.journal (the meshes it finished are kept)");
  addOutputFlags(cmd, o->flags);
  cmd->add_flag("--bitonic-sort", o->bitonicSort, "Sort candidates with the old bitonic sort (timing comparison)");
  cmd->add_option("--disc-raster", o->discRaster,
                  "Disc splatter of the voronoi and conflicts stages: compute, mesh, geometry or mesh-depth (same "
                  "order); all or "
                  "a comma list times each on the same G-buffer")
      ->capture_default_str();
  cmd->add_option("--points", o->points,
                  "Point clouds: cpu (exact farthest-point order), gpu (discs into the G-buffers + GPU sampler), "
                  "auto (gpu from 500k points when a GPU is there)")
      ->capture_default_str();
  cmd->add_option("--surfel-blocks", o->blocks,
                  ".mrg: surfels per SURF block, FIRST:MAX (powers of two; blocks double from FIRST to MAX, so any "
                  "byte prefix decodes to a surfel prefix)")
      ->capture_default_str();
  cmd->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->callback([o] { runSurfels(*o); });
}

} // namespace mirage::cli
