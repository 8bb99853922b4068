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
#include "mirage/visibility/pvs_eval.h"
#include "mirage/visibility/pvs_storage.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct PvsOptions {
  std::string input, cells, grid, region, output, method = "gvs";
  RayBackendChoice rays;
  vis::GvsConfig gvs;
  int threads = 0;
  bool json = false, noPackets = false, noDiff = false;
  // pvs-eval only
  vis::EvalConfig eval{.resolution = 1000, .haltonViewpoints = 4};
  uint64_t bruteRays = 0;
  std::string config;
  std::vector<std::pair<CLI::Option*, void (*)(vis::GvsConfig&, const vis::GvsConfig&)>> overrides;
};

// --config first, then every sampling flag given on the command line on top of it.
Status resolveConfig(PvsOptions& o) {
  if (o.config.empty()) return Ok{};
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

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

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

// Cells from --cells or --cell-grid. A file is read before the scene loads (cheap errors first);
// a grid needs the scene's bounds unless --cell-region is given.
Result<std::vector<vis::ViewCell>> cellsFromOptions(const PvsOptions& o, const Scene* scene) {
  if (o.cells.empty() == o.grid.empty()) return Error{"give exactly one of --cells FILE and --cell-grid NXxNYxNZ"};
  if (!o.cells.empty()) return vis::loadViewCells(o.cells);
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
  if (o.method != "gvs" && o.method != "rand") return Error{"--method must be gvs or rand"};
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

void runPvs(PvsOptions o) {
  if (auto s = resolveConfig(o); !s) return fail(s.error());
  if (auto s = checkOutputPath(o.output, {".mrg"}); !s) return fail(s.error());
  auto threads = limitThreads(o.threads);
  auto p = prepare(o);
  if (!p) return fail(p.error());
  vis::PvsData data;
  data.sceneTriangles = p->backend->triangleCount();
  data.cells = p->cells;
  nlohmann::json cellsJson = nlohmann::json::array();
  uint64_t rays = 0;
  double traceSeconds = 0, totalSeconds = 0;
  for (size_t i = 0; i < p->cells.size(); ++i) {
    // RAND spends --budget rays (or --rays when no budget is given) on random sampling alone.
    vis::GvsConfig cfg = o.method == "gvs"
                             ? o.gvs
                             : vis::randomOnlyConfig(o.gvs.rayBudget ? o.gvs.rayBudget : o.gvs.randomRays, o.gvs.seed);
    vis::CellPvs pvs = vis::computeCellPvs(*p->backend, p->scene, p->cells[i], cfg);
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
                         {"mrays_per_s", double(pvs.stats.rays) / pvs.stats.seconds * 1e-6}});
    data.triangles.push_back(std::move(pvs.triangles));
  }
  vis::PvsEncodeStats es;
  if (auto s = vis::savePvs(o.output, data, o.input, {.differences = !o.noDiff}, &es); !s) return fail(s.error());
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
      {"pvs_bytes", es.totalBytes},
      {"difference_cells", es.differenceCells},
      {"load_seconds", loadSeconds}};
  if (o.json) return fmt::print("{}\n", j.dump(2));
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
  nlohmann::json cells = nlohmann::json::array();
  double gvsSum = 0, randSum = 0;
  for (size_t i = 0; i < p->cells.size(); ++i) {
    const vis::ViewCell& cell = p->cells[i];
    vis::CellPvs gvs = vis::computeCellPvs(*p->backend, p->scene, cell, o.gvs);
    vis::CellPvs rnd =
        vis::computeCellPvs(*p->backend, p->scene, cell, vis::randomOnlyConfig(gvs.stats.rays, o.gvs.seed + 1));
    vis::TriangleSet set(p->backend->triangleCount());
    auto measure = [&](const vis::CellPvs& pvs, const char* name) {
      set.assign(pvs.triangles);
      vis::PixelError e = vis::evaluatePvs(*p->backend, cell, set, o.eval);
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
    gvsSum += ge;
    randSum += re;
    nlohmann::json c{{"cell", i}, {"gvs", gj}, {"rand", rj}};
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
    if (!o.json)
      fmt::print("cell {:3}: GVS++ {:8} tris {:10} rays {:5.2f} Mrays/s err {:9.2f} px/view (max {}, {} regions, "
                 "largest {}) | RAND {:8} tris err {:9.2f} px/view (max {}){}\n",
                 i, gvs.triangles.size(), gvs.stats.rays, gj["mrays_per_s"].get<double>(), ge,
                 gj["max_wrong"].get<uint64_t>(), gj["regions"].get<uint64_t>(), gj["largest_region"].get<uint64_t>(),
                 rnd.triangles.size(), re, rj["max_wrong"].get<uint64_t>(),
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
                   {"rand_over_gvs", gvsSum > 0 ? randSum / gvsSum : 0.0}};
  if (o.json) return fmt::print("{}\n", j.dump(2));
  fmt::print("average wrong pixels per {}x{} view: GVS++ {:.3f}, RAND {:.3f} (RAND/GVS++ = {})\n", o.eval.resolution,
             o.eval.resolution, gvsSum / n, randSum / n,
             gvsSum > 0 ? fmt::format("{:.1f}", randSum / gvsSum) : std::string("inf: GVS++ error is 0"));
}

void addCommon(CLI::App* cmd, PvsOptions& o) {
  cmd->add_option("input", o.input, "Scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]")->required();
  cmd->add_option("--cells", o.cells, "View cells as JSON (docs/visibility.md)");
  cmd->add_option("--cell-grid", o.grid, "NXxNYxNZ cells tiling --cell-region (default: the scene bounds)");
  cmd->add_option("--cell-region", o.region, "x0,y0,z0,x1,y1,z1 for --cell-grid (flat in y: rectangles)");
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
                  "Ray backend: auto (Vulkan on a GPU with ray-tracing pipelines, else Embree), embree or vulkan")
      ->capture_default_str();
  cmd->add_option("--device", o.rays.device, "Vulkan device name substring or index (--backend vulkan)");
  cmd->add_flag("--no-packets", o.noPackets, "Trace evaluation views ray by ray (rtcIntersect1), not in packets of 16");
  cmd->add_flag("--json", o.json, "Print results as JSON");
}

} // namespace

void addPvsCommands(CLI::App& app) {
  auto o = std::make_shared<PvsOptions>();
  auto* pvs = app.add_subcommand("pvs", "Bake GVS++ potentially visible sets for view cells into a .mrg");
  addCommon(pvs, *o);
  pvs->add_option("-o,--output", o->output, "Output .mrg ('PVS ' and 'META' chunks)")->required();
  pvs->add_flag("--no-diff", o->noDiff, "Store every cell in full (no differences against neighbours)");
  pvs->add_option("--method", o->method, "gvs (GVS++) or rand (random rays only: the baseline)")->capture_default_str();
  pvs->callback([o] { runPvs(*o); });

  auto e = std::make_shared<PvsOptions>();
  auto* eval = app.add_subcommand("pvs-eval", "Pixel error of GVS++ vs RAND (equal ray budget) per view cell");
  addCommon(eval, *e);
  eval->add_option("--size", e->eval.resolution, "Square view resolution (one ray per pixel)")->capture_default_str();
  eval->add_option("--viewpoints", e->eval.haltonViewpoints, "Halton viewpoints per cell besides the corners")
      ->capture_default_str();
  eval->add_option("--brute", e->bruteRays, "Also a brute-force reference with this many rays per round (0: off)")
      ->capture_default_str();
  eval->callback([e] { runEval(*e); });
}

} // namespace mirage::cli
