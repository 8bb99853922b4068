// mirage pvs / pvs-eval: bake GVS++ potentially visible sets into a .mrg, and measure their pixel
// error against the RAND baseline (and a brute-force reference) at an equal ray budget.
#include <chrono>
#include <fstream>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "cmd_list.h"
#include "commands.h"
#include "ray_backend_choice.h"
#include "mirage/visibility/gvs.h"
#include "mirage/core/input_text.h"
#include "mirage/visibility/pvs_eval.h"
#include "mirage/visibility/pvs_plot.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/bake/pvs_bake.h"
#include "mirage/bake/surfel_bake.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct PvsOptions {
  std::string input, cells, grid, region, output, method = "gvs";
  uint32_t streetCells = 0; // --cell-streets: cells per street of a gen:city input
  RayBackendChoice rays;
  vis::GvsConfig gvs;
  int threads = 0;
  uint32_t lanes = 0; // pvs: --cells-in-flight (0: the backend's preferredLanes)
  bool json = false, noPackets = false, noDiff = false;
  bool resume = false; // pvs: continue from the journal beside the output
  OutputFlags flags;   // --quiet, --progress
  // pvs-eval only
  vis::EvalConfig eval{.resolution = 1000, .haltonViewpoints = 4};
  uint64_t bruteRays = 0;
  uint32_t rasterSize = 64; // RASTER cube-map resolution (pvs --method raster, pvs-eval)
  std::string config, plot;
  std::vector<std::pair<CLI::Option*, void (*)(vis::GvsConfig&, const vis::GvsConfig&)>> overrides;
};

// --config first, then every sampling flag given on the command line on top of it.
Status resolveConfig(PvsOptions& o) {
  if (o.config.empty()) return Ok{};
  if (std::string problem = inputFileProblem(o.config); !problem.empty()) return makeError(o.config, problem);
  std::ifstream in(o.config, std::ios::binary);
  if (!in) return makeError(o.config, "cannot open");
  std::stringstream text;
  text << in.rdbuf();
  auto cfg = vis::parseGvsConfig(text.str(), o.config);
  if (!cfg) return cfg.error();
  for (const auto& [option, copy] : o.overrides)
    if (option->count() > 0) copy(*cfg, o.gvs);
  o.gvs = *cfg;
  return Ok{};
}

std::string countText(double n) {
  if (n < 1e4) return fmt::format("{:.0f}", n);
  if (n < 1e6) return fmt::format("{:.1f} k", n * 1e-3);
  if (n < 1e9) return fmt::format("{:.2f} M", n * 1e-6);
  return fmt::format("{:.2f} G", n * 1e-9);
}

// Progress on stderr while a bake runs (a bake of one cell can take minutes), through the shared
// reporter (mirage/core/progress.h): one task per cell and stage ("cell 2/16 GVS++"), counting
// rays of the budget (no ETA without one); the library reports through BakeOptions::progress and
// EvalConfig::progress.
struct CellProgress {
  Progress& out;
  size_t cells;
  size_t cell = 0;

  void begin(std::string_view stage, uint64_t total) {
    out.begin(fmt::format("cell {}/{} {}", cell + 1, cells, stage), total);
  }
  // "1.20 M rays, 4512 triangles, iteration 3"
  std::function<void(const vis::GvsProgress&)> bake() {
    return [this](const vis::GvsProgress& g) {
      out.update(
          g.rays, g.budget,
          fmt::format("{} rays, {} triangles, iteration {}", countText(double(g.rays)), g.triangles, g.iterations));
    };
  }
};

Result<Bounds> parseRegion(const std::string& text) {
  std::vector<float> v;
  std::stringstream s(text);
  std::string part;
  while (std::getline(s, part, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stof(part, &used));
      if (used != part.size()) v.clear();
    } catch (...) { // the CLI edge: std::stof's exceptions stop here
      return Error{"--cell-region: expected x0,y0,z0,x1,y1,z1, got \"" + text + "\""};
    }
  }
  if (v.size() != 6) return Error{"--cell-region: expected x0,y0,z0,x1,y1,z1, got \"" + text + "\""};
  Bounds b;
  b.add({v[0], v[1], v[2]});
  b.add({v[3], v[4], v[5]});
  return b;
}

// Cells along every street of a gen:city input (io::cityStreetCells).
Result<std::vector<vis::ViewCell>> streetCells(const PvsOptions& o) {
  auto gen = runtime::parseGenArgument(o.input);
  if (!gen || gen->kind != "city")
    return Error{"--cell-streets needs a gen:city[:BLOCKS[:SEED]] input, not " + o.input};
  auto city = io::cityOptions(gen->seed, gen->size);
  if (!city) return city.error();
  std::vector<vis::ViewCell> cells;
  for (const Bounds& b : io::cityStreetCells(*city, o.streetCells)) {
    vis::ViewCell c;
    c.shape = vis::CellShape::Box;
    c.position = b.center();
    c.size = b.extent();
    cells.push_back(c);
  }
  return cells;
}

// Cells from --cells, --cell-grid or --cell-streets. A file is read before the scene loads (cheap
// errors first); a grid needs the scene's bounds unless --cell-region is given.
Result<std::vector<vis::ViewCell>> cellsFromOptions(const PvsOptions& o, const Scene* scene) {
  if (int(!o.cells.empty()) + int(!o.grid.empty()) + int(o.streetCells > 0) != 1)
    return Error{"give exactly one of --cells FILE, --cell-grid NXxNYxNZ and --cell-streets N"};
  if (!o.cells.empty()) return vis::loadViewCells(o.cells);
  if (o.streetCells > 0) return streetCells(o);
  auto counts = vis::parseGridCounts(o.grid);
  if (!counts) return counts.error();
  Bounds region;
  if (!o.region.empty()) {
    auto r = parseRegion(o.region);
    if (!r) return r.error();
    region = *r;
  } else if (scene) {
    region = scene->worldBounds();
  } else {
    return std::vector<vis::ViewCell>{}; // the caller asks again once the scene is loaded
  }
  return vis::gridCells(region, *counts);
}

Status checkOptions(const PvsOptions& o) {
  if (o.threads < 0 || o.threads > 4096) return Error{"--threads must be in 0..4096"};
  if (auto s = checkRayBackendChoice(o.rays); !s) return s;
  if (o.gvs.randomRays == 0) return Error{"--rays must be at least 1"};
  if (o.method != "gvs" && o.method != "rand" && o.method != "raster")
    return Error{"--method must be gvs, rand or raster"};
  if (o.rasterSize < 1 || o.rasterSize > 8192) return Error{"--raster-size must be in 1..8192"};
  if (o.eval.resolution < 1 || o.eval.resolution > 8192) return Error{"--size must be in 1..8192"};
  return Ok{};
}

struct Prepared {
  Scene scene;
  std::vector<vis::ViewCell> cells;
  OpenedRayBackend opened; // the device (if any) and the backend
  vis::RayBackend* backend = nullptr;
  double loadSeconds = 0, buildSeconds = 0;
};

Result<Prepared> prepare(const PvsOptions& o) {
  if (auto s = checkOptions(o); !s) return s.error();
  auto early = cellsFromOptions(o, nullptr); // file errors before the (slow) scene load
  if (!early) return early.error();
  Prepared p;
  auto t0 = std::chrono::steady_clock::now();
  auto scene = loadSceneArgument(o.input);
  if (!scene) return scene.error();
  p.scene = std::move(*scene);
  p.loadSeconds = secondsSince(t0);
  auto cells = early->empty() ? cellsFromOptions(o, &p.scene) : std::move(early);
  if (!cells) return cells.error();
  p.cells = std::move(*cells);
  // Cells far outside the scene make rays no backend can trace: one line naming the cell.
  if (auto s = vis::validateCellsForScene(p.cells, p.scene.worldBounds(), o.cells.empty() ? "--cell-region" : o.cells);
      !s)
    return s.error();
  RayBackendChoice choice = o.rays;
  choice.packets = !o.noPackets;
  auto opened = openRayBackend(choice, p.scene);
  if (!opened) return opened.error();
  p.opened = std::move(*opened);
  p.backend = p.opened.backend.get();
  p.buildSeconds = p.opened.buildSeconds;
  return p;
}

std::unique_ptr<tbb::global_control> limitThreads(int threads) {
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, size_t(threads));
}

// The per-rank JSON of a bake spread over ranks (docs/bake.md).
nlohmann::json ranksJson(const bake::ScheduleReport& r) {
  nlohmann::json ranks = nlohmann::json::array();
  for (size_t i = 0; i < r.ranks.size(); ++i)
    ranks.push_back({{"rank", i}, {"units", r.ranks[i].units}, {"busy_seconds", r.ranks[i].busySeconds}});
  return ranks;
}

// Every rank runs the command: checks, scene and ray backend on each (the cells trace through the
// whole scene; a device per local rank), the cells spread over all (docs/bake.md), rank 0 writes
// and prints. Errors print once, on rank 0; every rank exits 2.
void runPvs(PvsOptions o) {
  auto world = bake::World::join();
  if (!world) return fail(world.error());
  auto failAll = [&](const Error& e) { return world->root() ? fail(e) : setExitCode(2); };
  if (auto s = resolveConfig(o); !s) return failAll(s.error());
  if (auto s = checkOutputPath(o.output, {".mrg"}); !s) return failAll(s.error());
  if (world->size() > 1 && o.threads == 0) o.threads = int(world->threadShare());
  if (o.rays.device.empty()) o.rays.device = bake::deviceForRank(*world);
  auto threads = limitThreads(o.threads);
  auto p = prepare(o);
  if (Status all = world->agree(p ? Status(Ok{}) : Status(p.error())); !all) return failAll(all.error());
  Progress reporter(world->root() ? o.flags.progressMode() : ProgressMode::None);
  CellProgress progress{reporter, p->cells.size()};
  const char* methodName = o.method == "gvs" ? "GVS++" : o.method == "rand" ? "RAND" : "RASTER";
  // Cells baked at once on this rank: lanes of the backend, each on its own thread.
  std::vector<std::unique_ptr<vis::RayBackend>> siblings;
  std::vector<vis::RayBackend*> lanes{p->backend};
  for (size_t want = o.lanes ? o.lanes : p->backend->preferredLanes(); lanes.size() < want;) {
    siblings.push_back(p->backend->sibling());
    if (!siblings.back()) break; // the backend has one lane
    lanes.push_back(siblings.back().get());
  }
  // In-cell progress with one lane (on rank 0 its baking thread, the only one printing); with more,
  // the cells done.
  const bool cellProgress = lanes.size() == 1;
  // One cell on this rank, on `backend`.
  auto bakeCell = [&](vis::RayBackend& backend, uint32_t i) {
    if (cellProgress) {
      progress.cell = i;
      progress.begin(methodName, o.method == "rand" && !o.gvs.rayBudget ? o.gvs.randomRays : o.gvs.rayBudget);
    }
    vis::BakeOptions bake{.progress = cellProgress ? progress.bake() : nullptr};
    // RAND spends --budget rays (or --rays when no budget is given) on random sampling alone.
    vis::GvsConfig cfg = o.method == "gvs"
                             ? o.gvs
                             : vis::randomOnlyConfig(o.gvs.rayBudget ? o.gvs.rayBudget : o.gvs.randomRays, o.gvs.seed);
    // RASTER spends --budget pixels (or --rays) on cube maps of --raster-size².
    vis::CellPvs pvs = o.method == "raster"
                           ? vis::rasterPvs(backend, p->cells[i],
                                            {.resolution = o.rasterSize,
                                             .pixelBudget = o.gvs.rayBudget ? o.gvs.rayBudget : o.gvs.randomRays,
                                             .seed = o.gvs.seed},
                                            {})
                           : vis::computeCellPvs(backend, p->scene, p->cells[i], cfg, bake);
    if (cellProgress)
      reporter.end(fmt::format("{} triangles, {} rays", pvs.triangles.size(), countText(double(pvs.stats.rays))));
    return pvs;
  };
  std::vector<bake::CellBaker> bakers;
  for (vis::RayBackend* lane : lanes) bakers.push_back([&bakeCell, lane](uint32_t i) { return bakeCell(*lane, i); });
  bake::UnitProgress cellsDone;
  if (!cellProgress && world->root()) {
    reporter.begin(fmt::format("{} cells", methodName), p->cells.size());
    cellsDone = [&](size_t done, size_t total, uint64_t, uint64_t) { reporter.update(done, total); };
  }
  std::string settings =
      fmt::format("{} {} {} {}", o.method, o.rasterSize, p->backend->name(), vis::gvsConfigToJson(o.gvs));
  uint64_t fingerprint = bake::pvsFingerprint(settings, p->cells, p->backend->triangleCount());
  bake::BakeRun run{bake::journalPath(o.output), o.resume};
  bake::ScheduleReport report;
  auto baked = bake::bakeCellPvs(*world, p->cells.size(), fingerprint, bakers, run, &report, cellsDone);
  if (!baked) return failAll(baked.error());
  if (cellsDone) reporter.end();
  if (!world->root()) { // rank 0 writes; every rank learns how that went
    if (Status all = world->agree(Ok{}); !all) setExitCode(2);
    return;
  }

  vis::PvsData data;
  data.sceneTriangles = p->backend->triangleCount();
  data.cells = p->cells;
  nlohmann::json cellsJson = nlohmann::json::array();
  uint64_t rays = 0;
  double traceSeconds = 0, totalSeconds = 0;
  vis::PvsStats phases; // summed over cells: where the time goes
  bool generated = false, exploreGenerated = false;
  for (size_t i = 0; i < baked->size(); ++i) {
    vis::CellPvs& pvs = (*baked)[i];
    phases.randomSeconds += pvs.stats.randomSeconds;
    phases.randomTraceSeconds += pvs.stats.randomTraceSeconds;
    phases.absSeconds += pvs.stats.absSeconds;
    phases.absTraceSeconds += pvs.stats.absTraceSeconds;
    phases.rsSeconds += pvs.stats.rsSeconds;
    phases.rsTraceSeconds += pvs.stats.rsTraceSeconds;
    phases.randomRays += pvs.stats.randomRays;
    phases.absRays += pvs.stats.absRays;
    phases.rsRays += pvs.stats.rsRays;
    generated = generated || pvs.stats.generatedRandomRays;
    exploreGenerated = exploreGenerated || pvs.stats.generatedExploreRays;
    rays += pvs.stats.rays;
    totalSeconds += pvs.stats.seconds;
    traceSeconds += pvs.stats.traceSeconds;
    cellsJson.push_back({{"cell", i},
                         {"triangles", pvs.triangles.size()},
                         {"rays", pvs.stats.rays},
                         {"random_rays", pvs.stats.randomRays},
                         {"abs_rays", pvs.stats.absRays},
                         {"rs_rays", pvs.stats.rsRays},
                         {"iterations", pvs.stats.iterations},
                         {"seconds", pvs.stats.seconds},
                         {"trace_seconds", pvs.stats.traceSeconds},
                         {"random_seconds", pvs.stats.randomSeconds},
                         {"random_trace_seconds", pvs.stats.randomTraceSeconds},
                         {"abs_seconds", pvs.stats.absSeconds},
                         {"abs_trace_seconds", pvs.stats.absTraceSeconds},
                         {"rs_seconds", pvs.stats.rsSeconds},
                         {"rs_trace_seconds", pvs.stats.rsTraceSeconds},
                         {"mrays_per_s", double(pvs.stats.rays) / pvs.stats.seconds * 1e-6}});
    data.triangles.push_back(std::move(pvs.triangles));
  }
  vis::PvsEncodeStats es;
  auto tWrite = std::chrono::steady_clock::now();
  Status written = vis::savePvs(o.output, data, o.input, {.differences = !o.noDiff}, &es);
  double writeSeconds = secondsSince(tWrite);
  if (Status all = world->agree(written); !all) return fail(all.error());
  bake::removeJournal(*world, {.journal = run.journal});
  // Load time: decode every cell back from the file, as a renderer would at start-up.
  auto t0 = std::chrono::steady_clock::now();
  auto back = vis::loadPvs(o.output);
  double loadSeconds = secondsSince(t0);
  if (!back) return fail(back.error());
  for (size_t i = 0; i < cellsJson.size(); ++i) cellsJson[i]["bytes"] = es.cellBytes[i];
  nlohmann::json j{
      {"input", o.input},
      {"output", o.output},
      {"scene_triangles", data.sceneTriangles},
      {"cells", cellsJson},
      {"rays", rays},
      {"seconds", traceSeconds},
      {"mrays_per_s", double(rays) / traceSeconds * 1e-6},
      {"threads", o.threads > 0 ? o.threads
                                : int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism))},
      {"backend", std::string(p->backend->name())},
      {"bvh_build_seconds", p->buildSeconds},
      {"random_rays_generated_on_device", generated},
      {"explore_rays_generated_on_device", exploreGenerated},
      {"pvs_bytes", es.totalBytes},
      {"difference_cells", es.differenceCells},
      {"load_seconds", loadSeconds},
      {"bake_seconds", report.seconds}, // wall: the cells on every rank, from the first handed out to the last back
      {"write_seconds", writeSeconds},  // encoding and writing the PVS chunk on rank 0
      {"ranks", world->size()},
      {"resumed_units", report.resumedUnits},
      {"per_rank", ranksJson(report)}};
  if (o.json) return fmt::print("{}\n", j.dump(2));
  if (o.flags.quiet) return;
  fmt::print("{}: {} triangles, {} cells, {} on {} (BVH {:.2f} s)\n", o.input, data.sceneTriangles, data.cells.size(),
             o.method, p->backend->name(), p->buildSeconds);
  for (const auto& c : cellsJson)
    fmt::print("cell {:4}: {:9} triangles  {:11} rays  {:3} iterations  {:6.2f} s  {:5.2f} Mrays/s  {:8} bytes\n",
               c["cell"].get<size_t>(), c["triangles"].get<size_t>(), c["rays"].get<uint64_t>(),
               c["iterations"].get<uint32_t>(), c["seconds"].get<double>(), c["mrays_per_s"].get<double>(),
               c["bytes"].get<uint64_t>());
  fmt::print("total {} rays in {:.2f} s: {:.2f} Mrays/s overall, {:.2f} Mrays/s in trace ({} threads)\n", rays,
             totalSeconds, double(rays) / totalSeconds * 1e-6, double(rays) / traceSeconds * 1e-6,
             j["threads"].get<int>());
  // Per phase: all of it and the share inside the backend; the rest is ray making and bookkeeping
  // on the host (for generated random rays, rebuilding the discovering rays).
  auto phase = [](const char* name, uint64_t n, double all, double trace) {
    fmt::print("  {:7} {:12} rays  {:7.2f} s  (trace {:7.2f} s, host {:7.2f} s)  {:8.2f} Mrays/s in trace\n", name, n,
               all, trace, all - trace, trace > 0 ? double(n) / trace * 1e-6 : 0.0);
  };
  fmt::print("phases (random rays made on the {}, border and reverse rays on the {}):\n", generated ? "device" : "host",
             exploreGenerated ? "device" : "host");
  phase("random", phases.randomRays, phases.randomSeconds, phases.randomTraceSeconds);
  phase("border", phases.absRays, phases.absSeconds, phases.absTraceSeconds);
  phase("reverse", phases.rsRays, phases.rsSeconds, phases.rsTraceSeconds);
  // The schedule between the phases: pricing and staging the queued work, checkpoints.
  fmt::print("  {:7} {:12}       {:7.2f} s\n", "other", "",
             totalSeconds - phases.randomSeconds - phases.absSeconds - phases.rsSeconds);
  fmt::print("{} -> {} bytes ({} difference cells), load {:.2f} ms\n", o.output, es.totalBytes, es.differenceCells,
             loadSeconds * 1e3);
}

nlohmann::json errorJson(const vis::PixelError& e) {
  return {{"views", e.views},
          {"pixels_per_view", e.pixelsPerView},
          {"average_wrong", e.averageWrong},
          {"max_wrong", e.maxWrong},
          {"average_fraction", e.averageFraction()},
          {"regions", e.regions},
          {"largest_region", e.largestRegion}};
}

void runEval(PvsOptions o) {
  if (auto s = resolveConfig(o); !s) return fail(s.error());
  auto threads = limitThreads(o.threads);
  auto p = prepare(o);
  if (!p) return fail(p.error());
  if (!o.plot.empty())
    if (auto s = checkOutputPath(o.plot, {".svg"}); !s) return fail(s.error());
  nlohmann::json cells = nlohmann::json::array();
  double gvsSum = 0, randSum = 0, rasterSum = 0;
  // --plot: PVS snapshots of every method at (about) the same ray counts, evaluated like the final
  // sets. Per method and checkpoint index: (rays, PVS size, error) summed over cells.
  // From one random batch (the bake's first step) up, doubling: error against budget, since a
  // bake's schedule does not depend on its budget (a bake cut at N rays is this snapshot).
  std::vector<uint64_t> requested;
  if (!o.plot.empty())
    for (uint64_t r = std::max<uint64_t>(1, std::min<uint64_t>(o.gvs.randomRays, p->backend->preferredBatchRays()));
         requested.size() < 24; r *= 2)
      requested.push_back(r);
  std::vector<vis::PlotSeries> series{{"GVS++", {}}, {"RAND", {}}, {"RASTER", {}}};
  size_t plotPoints = SIZE_MAX;
  std::vector<std::vector<std::vector<vis::PlotPoint>>> perCell(3);
  Progress reporter(o.flags.progressMode());
  CellProgress progress{reporter, p->cells.size()};
  for (size_t i = 0; i < p->cells.size(); ++i) {
    const vis::ViewCell& cell = p->cells[i];
    progress.cell = i;
    progress.begin("GVS++", o.gvs.rayBudget);
    vis::CellPvs gvs = vis::computeCellPvs(*p->backend, p->scene, cell, o.gvs,
                                           {.checkpointRays = requested, .progress = progress.bake()});
    // RAND and RASTER snapshot where GVS++ did, so the series share their x positions. RAND has
    // the same seed: its rays are the random rays GVS++ traced and as many more, so the two
    // differ in what GVS++ did with the rest of its rays, not in the luck of the draw.
    progress.begin("RAND", gvs.stats.rays);
    vis::BakeOptions same{.progress = progress.bake()};
    for (const auto& c : gvs.checkpoints) same.checkpointRays.push_back(c.rays);
    vis::CellPvs rnd =
        vis::computeCellPvs(*p->backend, p->scene, cell, vis::randomOnlyConfig(gvs.stats.rays, o.gvs.seed), same);
    // RASTER at the same cost: as many ID pixels as GVS++ traced rays.
    progress.begin("RASTER cube maps", 0);
    vis::CellPvs ras = vis::rasterPvs(
        *p->backend, cell, {.resolution = o.rasterSize, .pixelBudget = gvs.stats.rays, .seed = o.gvs.seed}, same);
    vis::TriangleSet set(p->backend->triangleCount());
    size_t evaluations = 0;
    auto errorOf = [&](const std::vector<uint32_t>& triangles) {
      set.assign(triangles);
      vis::EvalConfig ec = o.eval;
      ++evaluations;
      progress.begin(fmt::format("evaluation {}", evaluations), 0);
      ec.progress = [&](uint32_t views, uint32_t total) { reporter.update(views, total, "views"); };
      return vis::evaluatePvs(*p->backend, cell, set, ec);
    };
    if (!o.plot.empty()) {
      const vis::CellPvs* methods[3] = {&gvs, &rnd, &ras};
      for (int m = 0; m < 3; ++m) {
        std::vector<vis::PlotPoint> pts;
        for (const auto& c : methods[m]->checkpoints)
          pts.push_back({double(c.rays), double(c.triangles.size()), errorOf(c.triangles).averageWrong});
        perCell[size_t(m)].push_back(std::move(pts));
      }
    }
    auto measure = [&](const vis::CellPvs& pvs, const char* name) {
      vis::PixelError e = errorOf(pvs.triangles);
      nlohmann::json j = errorJson(e);
      j["triangles"] = pvs.triangles.size();
      j["rays"] = pvs.stats.rays;
      j["seconds"] = pvs.stats.seconds;
      j["mrays_per_s"] = double(pvs.stats.rays) / pvs.stats.seconds * 1e-6;
      j["name"] = name;
      return std::pair(j, e.averageWrong);
    };
    auto [gj, ge] = measure(gvs, "gvs++");
    auto [rj, re] = measure(rnd, "rand");
    auto [aj, ae] = measure(ras, "raster");
    aj["cube_maps"] = ras.stats.iterations;
    aj["resolution"] = o.rasterSize;
    gvsSum += ge;
    randSum += re;
    rasterSum += ae;
    if (!o.plot.empty()) {
      const vis::CellPvs* methods[3] = {&gvs, &rnd, &ras};
      const double errors[3] = {ge, re, ae};
      for (int m = 0; m < 3; ++m) {
        auto& pts = perCell[size_t(m)].back();
        // The final set, unless the last checkpoint was taken at the very end.
        if (!pts.empty() && pts.back().rays >= double(methods[m]->stats.rays)) pts.pop_back();
        pts.push_back({double(methods[m]->stats.rays), double(methods[m]->triangles.size()), errors[m]});
        plotPoints = std::min(plotPoints, pts.size());
      }
    }
    nlohmann::json c{{"cell", i}, {"gvs", gj}, {"rand", rj}, {"raster", aj}};
    if (o.bruteRays > 0) {
      vis::CellPvs ref = vis::bruteForcePvs(*p->backend, p->scene, cell, o.bruteRays);
      size_t found = 0;
      for (uint32_t id : ref.triangles) found += std::binary_search(gvs.triangles.begin(), gvs.triangles.end(), id);
      c["brute"] = {{"triangles", ref.triangles.size()},
                    {"rays", ref.stats.rays},
                    {"gvs_missing", ref.triangles.size() - found},
                    {"gvs_extra", gvs.triangles.size() - found}};
    }
    cells.push_back(c);
    reporter.end(fmt::format("GVS++ {:.2f}, RAND {:.2f} wrong px/view", ge, re));
    if (!o.json && !o.flags.quiet)
      fmt::print("cell {:3}: GVS++ {:8} tris {:10} rays {:5.2f} Mrays/s err {:9.2f} px/view (max {}, {} regions, "
                 "largest {}) | RAND {:8} tris err {:9.2f} px/view (max {}) | RASTER {:8} tris ({} cube maps "
                 "of {}²) err {:9.2f} px/view (max {}){}\n",
                 i, gvs.triangles.size(), gvs.stats.rays, gj["mrays_per_s"].get<double>(), ge,
                 gj["max_wrong"].get<uint64_t>(), gj["regions"].get<uint64_t>(), gj["largest_region"].get<uint64_t>(),
                 rnd.triangles.size(), re, rj["max_wrong"].get<uint64_t>(), ras.triangles.size(), ras.stats.iterations,
                 o.rasterSize, ae, aj["max_wrong"].get<uint64_t>(),
                 o.bruteRays ? fmt::format(" | brute {} tris, GVS++ misses {}", c["brute"]["triangles"].get<size_t>(),
                                           c["brute"]["gvs_missing"].get<size_t>())
                             : std::string());
  }
  double n = double(p->cells.size());
  nlohmann::json j{{"input", o.input},
                   {"scene_triangles", p->backend->triangleCount()},
                   {"resolution", o.eval.resolution},
                   {"cells", cells},
                   {"gvs_average_wrong", gvsSum / n},
                   {"rand_average_wrong", randSum / n},
                   {"raster_average_wrong", rasterSum / n},
                   {"rand_over_gvs", gvsSum > 0 ? randSum / gvsSum : 0.0},
                   {"raster_over_gvs", gvsSum > 0 ? rasterSum / gvsSum : 0.0}};
  if (!o.plot.empty()) {
    // Checkpoint k of every cell (the first plotPoints reached everywhere), then the final sets:
    // averaged over cells. The last entry of each cell's list is its final set.
    for (int m = 0; m < 3; ++m) {
      const size_t count = plotPoints; // includes the final point
      for (size_t k = 0; k < count; ++k) {
        vis::PlotPoint avg;
        for (const auto& cellPoints : perCell[size_t(m)]) {
          const vis::PlotPoint& pt = k + 1 == count ? cellPoints.back() : cellPoints[k];
          avg.rays += pt.rays / n;
          avg.pvsTriangles += pt.pvsTriangles / n;
          avg.averageWrong += pt.averageWrong / n;
        }
        series[size_t(m)].points.push_back(avg);
      }
    }
    std::string svg = vis::pvsPlotSvg(series, fmt::format("{}: PVS size and pixel error against rays", o.input));
    std::ofstream out(o.plot, std::ios::binary);
    out << svg;
    if (!out) return fail(makeError(o.plot, "cannot write"));
    nlohmann::json plot = nlohmann::json::array();
    for (const auto& s : series)
      for (const auto& pt : s.points)
        plot.push_back({{"method", s.name},
                        {"rays", pt.rays},
                        {"triangles", pt.pvsTriangles},
                        {"average_wrong", pt.averageWrong}});
    j["plot"] = plot;
  }
  if (o.json) return fmt::print("{}\n", j.dump(2));
  if (o.flags.quiet) return;
  fmt::print("average wrong pixels per {}x{} view: GVS++ {:.3f}, RAND {:.3f}, RASTER {:.3f} (RAND/GVS++ = {}, "
             "RASTER/GVS++ = {})\n",
             o.eval.resolution, o.eval.resolution, gvsSum / n, randSum / n, rasterSum / n,
             gvsSum > 0 ? fmt::format("{:.1f}", randSum / gvsSum) : std::string("inf"),
             gvsSum > 0 ? fmt::format("{:.1f}", rasterSum / gvsSum) : std::string("inf"));
  if (!o.plot.empty()) fmt::print("plot: {}\n", o.plot);
}

void addCommon(CLI::App* cmd, PvsOptions& o) {
  cmd->add_option("input", o.input, "Scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]")->required();
  cmd->add_option("--cells", o.cells, "View cells as JSON (docs/visibility.md)");
  cmd->add_option("--cell-grid", o.grid, "NXxNYxNZ cells tiling --cell-region (default: the scene bounds)");
  cmd->add_option("--cell-region", o.region, "x0,y0,z0,x1,y1,z1 for --cell-grid (flat in y: rectangles)");
  cmd->add_option("--cell-streets", o.streetCells,
                  "gen:city input: N cells along every street, 4 x 2 x 4 m at eye height (a walk through the city)")
      ->check(CLI::Range(1u, 100000u));
  cmd->add_option("--config", o.config, "GVS++ parameters as JSON (docs/visibility.md); flags override it");
  // Each sampling flag remembers how to copy itself over a --config file's value.
#define MIRAGE_GVS_FLAG(flag, field, help)                                                                             \
  o.overrides.push_back({cmd->add_option(flag, o.gvs.field, help)->capture_default_str(),                              \
                         [](vis::GvsConfig& to, const vis::GvsConfig& from) { to.field = from.field; }})
  MIRAGE_GVS_FLAG("--rays", randomRays, "n_rand: random rays per iteration");
  MIRAGE_GVS_FLAG("--abs-edge", absEdgeSamples, "n_ABSEdge");
  MIRAGE_GVS_FLAG("--rs-edge", rsEdgeSamples, "n_RSEdge");
  MIRAGE_GVS_FLAG("--rs-area", rsAreaSamples, "n_RSArea");
  MIRAGE_GVS_FLAG("--min-new", minNewTriangles, "T: termination threshold");
  MIRAGE_GVS_FLAG("--stable", stableIterations, "k: iterations below T before stopping");
  MIRAGE_GVS_FLAG("--budget", rayBudget, "Stop after this many rays per cell (0: none)");
  MIRAGE_GVS_FLAG("--seed", seed, "Sampling seed");
#undef MIRAGE_GVS_FLAG
  cmd->add_option("--threads", o.threads, "Worker threads (0: all cores)")->capture_default_str();
  cmd->add_option("--geometry", o.rays.geometry, "Ray-tracing geometry: auto, flatten or instance")
      ->capture_default_str();
  cmd->add_option("--backend", o.rays.backend,
                  "Ray backend: auto (Vulkan on a GPU, else Embree), embree, vulkan (the ray-tracing pipeline, "
                  "or compute where the device has none), compute (compute-shader BVH traversal) or one of its "
                  "variants: compute-persistent, compute-bvh2, compute-bvh2-persistent, compute-bvh2-shared-stack, "
                  "compute-bvh8, compute-bvh8-persistent, compute-bvh8-postpone")
      ->capture_default_str();
  cmd->add_option("--device", o.rays.device, "Vulkan device name substring or index (--backend vulkan|compute)");
  cmd->add_flag("--host-exploration", o.rays.hostExploration,
                "Vulkan: make the GVS++ border and reverse rays on the host and upload them (for comparison)");
  cmd->add_flag("--no-packets", o.noPackets, "Trace evaluation views ray by ray (rtcIntersect1), not in packets of 16");
  cmd->add_flag("--json", o.json, "Print results as JSON");
  addOutputFlags(cmd, o.flags);
  cmd->add_option("--raster-size", o.rasterSize, "RASTER cube-map face resolution")->capture_default_str();
}

} // namespace

void addPvsCommands(CLI::App& app) {
  auto o = std::make_shared<PvsOptions>();
  auto* pvs = app.add_subcommand("pvs", "Bake GVS++ potentially visible sets for view cells into a .mrg");
  addCommon(pvs, *o);
  pvs->add_option("-o,--output", o->output, "Output .mrg ('PVS ' and 'META' chunks)")->required();
  pvs->add_flag("--no-diff", o->noDiff, "Store every cell in full (no differences against neighbours)");
  pvs->add_option("--method", o->method,
                  "gvs (GVS++), rand (random rays only) or raster (ID cube maps at Halton points in the cell)")
      ->capture_default_str();
  pvs->add_option("--cells-in-flight", o->lanes,
                  "View cells baked at once per process, each on its own lane of the Vulkan ray backend (0: 2 on "
                  "a GPU, 1 on a CPU device and with Embree)")
      ->check(CLI::Range(0u, 16u))
      ->capture_default_str();
  pvs->add_flag("--resume", o->resume,
                "Continue a bake that died: keep the cells finished in OUTPUT.journal, bake the rest (docs/bake.md)");
  pvs->footer("Distributed: mpirun -np N mirage pvs ... spreads the cells over N processes, each with the scene and "
              "its own ray backend (a GPU per local rank); one .mrg, the same bytes as one process. docs/bake.md.");
  pvs->callback([o] { runPvs(*o); });

  auto e = std::make_shared<PvsOptions>();
  auto* eval = app.add_subcommand("pvs-eval", "Pixel error of GVS++ vs RAND (equal ray budget) per view cell");
  addCommon(eval, *e);
  eval->add_option("--size", e->eval.resolution, "Square view resolution (one ray per pixel)")->capture_default_str();
  eval->add_option("--viewpoints", e->eval.haltonViewpoints, "Halton viewpoints per cell besides the corners")
      ->capture_default_str();
  eval->add_option("--brute", e->bruteRays, "Also a brute-force reference with this many rays per round (0: off)")
      ->capture_default_str();
  eval->add_option("--plot", e->plot, "Write an SVG of PVS size and pixel error against rays (GVS++, RAND, RASTER)");
  eval->callback([e] { runEval(*e); });
}

} // namespace mirage::cli
