// mirage build INPUT... -o scene.mrg [--materials mats.toml]: bake cluster-LOD DAGs into a .mrg
// asset, with a material file's materials and point lights applied (stored in the SCEN chunk).
// Under mpirun the meshes are spread over the ranks (docs/bake.md); --resume continues a bake that died.
// mirage verify scene.mrg: structural checks and random-cut watertightness of every DAG.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "lod_common.h"
#include "mirage/asset/container.h"
#include "mirage/bake/lod_bake.h"
#include "mirage/bake/lod_stream_bake.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/lod/stream_bake.h"
#include "mirage/io/generate.h"
#include "mirage/runtime/scene_argument.h"
#include "mirage/lod/verify.h"
#include "mirage/shading/material_file.h"
#include "render_common.h"
#include "render_options.h"

namespace mirage::cli {

namespace {

struct BuildOptions {
  std::vector<std::string> inputs;
  std::string output;
  std::string materials; // material file applied before the bake (docs/shading.md)
  lod::BuildConfig config;
  lod::LodWriteOptions write;
  lod::StreamBakeOptions stream; // gen:many: meshes made and baked a few at a time (lod/stream_bake.h)
  bool resume = false;           // continue from the journal beside the output (docs/bake.md)
  bool quiet = false;
  bool json = false;
};

// The per-rank JSON of a bake spread over ranks (docs/bake.md).
nlohmann::json ranksJson(const bake::ScheduleReport& r) {
  nlohmann::json ranks = nlohmann::json::array();
  for (size_t i = 0; i < r.ranks.size(); ++i)
    ranks.push_back({{"rank", i}, {"units", r.ranks[i].units}, {"busy_seconds", r.ranks[i].busySeconds}});
  return ranks;
}

// gen:many: each mesh generated when a worker bakes it, chunks written as their turn comes, so the
// memory stays that of a few meshes whatever the scene's size (lod/stream_bake.h). Under mpirun every
// rank generates and bakes the meshes rank 0 hands it (bake/lod_stream_bake.h). --resume keeps the
// partial output and a journal of the meshes written, and continues them (docs/bake.md).
void runStreamedBuild(const BuildOptions& o, const io::ManyOptions& many, const bake::World& world) {
  if (o.inputs.size() != 1) return fail("gen:many is baked alone (one input)");
  if (!o.materials.empty()) return fail("--materials does not apply to gen:many");
  lod::MeshSource source;
  source.layout = io::generateManyLayout(many);
  source.mesh = [&many](uint32_t i) -> Result<Mesh> { return io::generateManyMesh(many, i); };
  source.key = fmt::format("gen:many:{}x{}:{}", many.count, many.triangles, many.seed);
  bool showProgress = !o.quiet && isatty(STDERR_FILENO);
  auto progress = [&](size_t meshes, size_t meshCount, uint64_t, uint64_t) {
    if (!showProgress) return;
    std::fprintf(stderr, "\rbuilding mesh %zu/%zu", meshes, meshCount);
    if (meshes == meshCount) std::fprintf(stderr, "\n");
  };
  lod::StreamBakeReport report;
  bake::ScheduleReport ranks;
  auto t0 = std::chrono::steady_clock::now();
  bake::BakeRun run{bake::journalPath(o.output), o.resume};
  if (Status s =
          bake::bakeLodFile(world, source, o.output, o.config, o.write, o.stream, &report, &ranks, progress, run);
      !s)
    return world.root() ? fail(s.error()) : setExitCode(2);
  if (!world.root()) return;
  double wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  uint64_t peakRss = procStatusBytes("VmHWM:");
  if (o.quiet) return;
  if (o.json) {
    nlohmann::json j = {{"output", o.output},
                        {"streamed", true},
                        {"ranks", world.size()},
                        {"per_rank", ranksJson(ranks)},
                        {"meshes", report.meshes},
                        {"resumed_units", report.resumedMeshes},
                        {"input_triangles", report.inputTriangles},
                        {"clusters", report.clusters},
                        {"pages", report.pages},
                        {"file_bytes", report.fileBytes},
                        {"meshes_in_flight", report.meshesInFlight},
                        {"reorder_window", report.reorderWindow},
                        {"threads_per_mesh", report.threadsPerMesh},
                        {"peak_meshes_in_flight", report.peakMeshesInFlight},
                        {"peak_meshes_waiting", report.peakMeshesWaiting},
                        {"build_seconds", report.bakeSeconds},
                        {"finish_seconds", report.finishSeconds},
                        {"mesh_seconds_summed",
                         {{"make", report.makeSeconds},
                          {"bake", report.meshBakeSeconds},
                          {"encode", report.encodeSeconds},
                          {"read_back", report.readBackSeconds}}},
                        {"wall_seconds", wallSeconds},
                        {"input_triangles_per_second", double(report.inputTriangles) / report.bakeSeconds},
                        {"peak_rss_bytes", peakRss}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print(
      "built {} (streamed): {} meshes{}, {} input triangles, {} clusters{} in {:.2f} s wall (bake and write {:.2f} s "
      "at {:.2f} M triangles/s, finish {:.2f} s); {} meshes in flight x {} threads, peak RSS {:.1f} MB, {} bytes\n",
      o.output, report.meshes, report.resumedMeshes ? fmt::format(" ({} resumed)", report.resumedMeshes) : "",
      report.inputTriangles, report.clusters, o.write.paged ? fmt::format(", {} pages", report.pages) : "", wallSeconds,
      report.bakeSeconds, double(report.inputTriangles) / report.bakeSeconds * 1e-6, report.finishSeconds,
      report.meshesInFlight, report.threadsPerMesh, double(peakRss) / 1e6, report.fileBytes);
}

// Every rank runs the command: the checks on each, the import on rank 0 (all agree on its outcome
// before the bake starts), the meshes spread over all, and rank 0 writes and prints. Errors print
// once, on rank 0; every rank exits 2.
void runBuild(const BuildOptions& o) {
  auto world = bake::World::join();
  if (!world) return fail(world.error());
  auto failAll = [&](const Error& e) { return world->root() ? fail(e) : setExitCode(2); };
  if (auto s = checkOutputPath(o.output, {".mrg"}); !s) return failAll(s.error());
  if (o.config.clusterTriangles < 4 || o.config.clusterTriangles > lod::kMaxClusterTriangles ||
      o.config.clusterTriangles % 4)
    return failAll(Error{fmt::format("--cluster-triangles must be a multiple of 4 in 4..{} (the renderer's limit)",
                                     lod::kMaxClusterTriangles)});
  if (o.config.groupClusters < 2 || o.config.groupClusters > 64)
    return failAll(Error{"--group-clusters must be in 2..64"});
  if (o.write.pages.pageBytes < 4096 || o.write.pages.pageBytes > (16u << 20))
    return failAll(Error{"--page-size must be in 4KB..16MB"});
  if (o.inputs.size() >= 1)
    if (auto many = runtime::manySceneArgument(o.inputs[0])) {
      if (!*many) return failAll(many->error());
      return runStreamedBuild(o, **many, *world);
    }
  auto t0 = std::chrono::steady_clock::now();
  auto secondsSince = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  shading::MaterialFile materials;
  Result<Scene> scene = Scene{};
  Status loaded = [&]() -> Status {
    if (!world->root()) return Ok{}; // rank 0 sends each rank the meshes it bakes
    if (!o.materials.empty()) {      // read first: a bad material file costs no import
      auto file = shading::loadMaterialFile(o.materials);
      if (!file) return file.error();
      materials = std::move(*file);
    }
    scene = loadScenes(o.inputs);
    if (!scene) return scene.error();
    if (!o.materials.empty()) return shading::applyMaterials(*scene, materials);
    return Ok{};
  }();
  if (Status all = world->agree(loaded); !all) return failAll(all.error());
  double importSeconds = secondsSince(t0);

  bool showProgress = world->root() && !o.quiet && isatty(STDERR_FILENO);
  auto progress = [&](size_t meshes, size_t meshCount, uint64_t done, uint64_t total) {
    if (!showProgress) return;
    int width = 40, filled = total ? int(double(done) / double(total) * width) : width;
    std::fprintf(stderr, "\rbuilding [%-*s] %3d%%  mesh %zu/%zu", width, std::string(size_t(filled), '#').c_str(),
                 total ? int(100.0 * double(done) / double(total)) : 100, meshes, meshCount);
    if (meshes == meshCount) std::fprintf(stderr, "\n");
  };
  auto t1 = std::chrono::steady_clock::now();
  bake::BakeRun run{bake::journalPath(o.output), o.resume};
  bake::ScheduleReport report;
  auto baked = bake::bakeLodAsset(*world, *scene, o.config, run, &report, progress);
  if (!baked) return failAll(baked.error());
  double buildSeconds = secondsSince(t1);
  auto t2 = std::chrono::steady_clock::now();
  // Rank 0 writes with --threads, or all the host's cores: the other ranks wait meanwhile.
  lod::LodWriteOptions write = o.write;
  write.threads = o.config.threads;
  Status written = world->root() ? lod::saveLodAsset(o.output, *baked, write) : Status(Ok{});
  if (Status all = world->agree(written); !all) return failAll(all.error());
  bake::removeJournal(*world, {.journal = run.journal});
  double writeSeconds = secondsSince(t2), wallSeconds = secondsSince(t0);
  if (o.quiet || !world->root()) return; // errors only; rank 0 speaks for the job
  uint64_t triangles = scene->meshTriangleCount();
  BuildSummary summary = summarize(*baked, o.output);
  if (o.json) {
    nlohmann::json j = summaryJson(summary);
    j["output"] = o.output;
    j["import_seconds"] = importSeconds;
    j["build_seconds"] = buildSeconds;
    j["write_seconds"] = writeSeconds; // encode, compress, write, read back
    j["wall_seconds"] = wallSeconds;
    j["input_triangles_per_second"] = double(triangles) / buildSeconds;
    j["ranks"] = world->size();
    j["resumed_units"] = report.resumedUnits;
    j["per_rank"] = ranksJson(report);
    fmt::print("{}\n", j.dump(2));
    return;
  }
  std::string ranks = world->size() > 1 ? fmt::format(" on {} ranks", world->size()) : "";
  std::string resumed = report.resumedUnits ? fmt::format(", {} meshes resumed", report.resumedUnits) : "";
  fmt::print("built {}: {} meshes, {} instances in {:.2f} s wall{} (import {:.2f} s, bake {:.2f} s at {:.2f} M "
             "triangles/s{}, write {:.2f} s)\n",
             o.output, scene->meshes.size(), scene->instances.size(), wallSeconds, ranks, importSeconds, buildSeconds,
             double(triangles) / buildSeconds * 1e-6, resumed, writeSeconds);
  printSummary(summary);
}

struct VerifyOptions {
  std::string input;
  int cuts = 100;
  uint32_t seed = 1;
  bool json = false;
  OutputFlags flags;
};

void runVerify(const VerifyOptions& o) {
  if (o.cuts < 0 || o.cuts > 100000) return fail("--cuts must be in 0..100000");
  auto t0 = std::chrono::steady_clock::now();
  auto a = lod::loadLodAsset(o.input);
  if (!a) return fail(a.error());
  double loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A paged file's load read and checked every page (checksums, page decoder, reassembly); a file
  // with CDAG chunks is loaded from those.
  uint64_t pagesChecked = 0;
  if (auto reader = asset::AssetReader::open(o.input); reader && !reader->find(asset::chunk::ClusterDag))
    if (auto paged = lod::openPagedMeshes(*reader))
      for (const lod::PagedMesh& m : *paged) pagesChecked += m.table.pages.size();
  std::mt19937 rng(o.seed);
  size_t cutsChecked = 0;
  // One unit per mesh's structural check and one per cut.
  Progress progress(o.flags.progressMode());
  progress.begin("verify", uint64_t(a->dags.size()) * uint64_t(o.cuts + 1));
  for (size_t i = 0; i < a->dags.size(); ++i) {
    const lod::ClusterDag& dag = a->dags[i];
    std::string where = fmt::format("{}: mesh {} '{}'", o.input, i, a->scene.meshes[i].name);
    if (Status s = lod::verifyDag(dag); !s) return fail(where + ": " + s.error().message);
    progress.advance(1, fmt::format("mesh {}/{}: structure", i + 1, a->dags.size()));
    Mesh reference = lod::levelZeroMesh(dag);
    float maxError = 0.0f;
    for (const lod::Group& g : dag.groups) maxError = std::max(maxError, g.bounds.error);
    for (int c = 0; c < o.cuts; ++c) {
      // Thresholds spread log-uniformly: most of the DAG's levels sit at small errors.
      float u = std::uniform_real_distribution<float>(0.0f, 1.0f)(rng);
      float tau = c == 0 ? 0.0f : maxError * 1.05f * std::pow(1e-4f, 1.0f - u);
      auto cut = lod::selectCut(dag, tau);
      if (Status s = lod::verifyCut(dag, cut, reference); !s)
        return fail(fmt::format("{}: cut at threshold {:.6g}: {}", where, tau, s.error().message));
      ++cutsChecked;
      progress.advance(1, fmt::format("mesh {}/{}: cut {}/{}", i + 1, a->dags.size(), c + 1, o.cuts));
    }
  }
  progress.end();
  // Wall time of the whole command (load and decode included), not of the checks alone.
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (o.json) {
    fmt::print("{}\n", nlohmann::json{{"file", o.input},
                                      {"meshes", a->dags.size()},
                                      {"cuts_checked", cutsChecked},
                                      {"pages_checked", pagesChecked},
                                      {"ok", true},
                                      {"load_seconds", loadSeconds},
                                      {"seconds", seconds}}
                           .dump(2));
    return;
  }
  if (o.flags.quiet) return;
  std::string pages = pagesChecked ? fmt::format("; {} pages checked", pagesChecked) : "";
  fmt::print("{}: ok: {} DAGs structurally valid{}; {} random cuts watertight and overlap-free ({:.2f} s wall, load "
             "{:.2f} s)\n",
             o.input, a->dags.size(), pages, cutsChecked, seconds, loadSeconds);
}

} // namespace

void addBuildCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("build", "Bake cluster-LOD DAGs of every mesh into a .mrg asset");
  cmd->footer("Distributed: mpirun -np N mirage build ... spreads the meshes over N processes (one .mrg, the same "
              "bytes as one process gives); finished meshes are kept in OUTPUT.journal until the output is written, "
              "and --resume continues from it after a rank or the job died. gen:many journals only with --resume: "
              "it then keeps OUTPUT.partial and OUTPUT.tmap beside the journal, and a signal (Ctrl-C, a batch "
              "walltime's SIGTERM) leaves them for the next --resume; without it a signal leaves nothing. "
              "docs/bake.md.");
  auto o = std::make_shared<BuildOptions>();
  cmd->add_option("inputs", o->inputs, "Scene files (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]")->required();
  cmd->add_option("-o,--output", o->output, "Output .mrg")->required();
  bindMaterials(*cmd, o->materials);
  cmd->add_option("--cluster-triangles", o->config.clusterTriangles, "Triangles per cluster (multiple of 4)")
      ->capture_default_str();
  cmd->add_option("--cluster-vertices", o->config.clusterVertices, "Vertices per cluster (<= 255)")
      ->capture_default_str();
  cmd->add_option("--normal-weight", o->config.normalWeight,
                  "Weight of the shading term in the LOD error (0 = geometric error only)")
      ->capture_default_str();
  cmd->add_option("--group-clusters", o->config.groupClusters, "Clusters per simplification group")
      ->capture_default_str();
  cmd->add_flag("--paged", o->write.paged, "Store each DAG as pages (CPAG chunks) instead of one CDAG chunk");
  cmd->add_option("--page-size", o->write.pages.pageBytes, "Encoded bytes per page, e.g. 128KB (implies --paged)")
      ->transform(CLI::AsSizeValue(false))
      ->each([o](const std::string&) { o->write.paged = true; })
      ->capture_default_str();
  cmd->add_option("--threads", o->config.threads,
                  "Worker threads per process (0 = all cores; under mpirun the host's cores over its ranks)")
      ->capture_default_str();
  cmd->add_option("--meshes-in-flight", o->stream.meshesInFlight,
                  "gen:many: meshes baked at once, each on threads / N (0 = half the threads)")
      ->capture_default_str();
  cmd->add_option("--reorder-window", o->stream.reorderWindow,
                  "gen:many: finished meshes that may wait for their turn to be written (0 = 2 x in flight)")
      ->capture_default_str();
  cmd->add_flag("--resume", o->resume,
                "Continue a bake that died: keep the meshes finished in OUTPUT.journal, bake the rest (gen:many: "
                "also makes the bake resumable)");
  cmd->add_flag("--quiet", o->quiet, "Print nothing but errors");
  cmd->add_flag("--json", o->json, "Print results as JSON");
  cmd->callback([o] { runBuild(*o); });

  auto* v = app.add_subcommand("verify", "Check a .mrg: DAG structure and watertight, overlap-free random cuts");
  auto vo = std::make_shared<VerifyOptions>();
  v->add_option("input", vo->input, "A .mrg built by mirage build")->required();
  v->add_option("--cuts", vo->cuts, "Random thresholds per mesh")->capture_default_str();
  v->add_option("--seed", vo->seed, "Seed of the thresholds")->capture_default_str();
  v->add_flag("--json", vo->json, "Print results as JSON");
  addOutputFlags(v, vo->flags);
  v->callback([vo] { runVerify(*vo); });
}

} // namespace mirage::cli
