// mirage demo: the main job on an embedded default. Generates procedural scenes (no downloaded
// asset), writes them as GLB, renders a few views to PNG, then runs the pipeline on the blob: bake
// a cluster-LOD .mrg, verify it, render it GPU-driven, sample blue-noise surfels. It says where
// everything is; then bakes potentially visible sets for a few city view cells. The example
// particle effects are rendered over a ground.
#include <algorithm>
#include <chrono>
#include <filesystem>

#include <fmt/format.h>

#include "cmd_list.h"
#include "example_effects.h"
#include "commands.h"
#include "mirage/io/generate.h"
#include "mirage/io/gltf_write.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/verify.h"
#include "mirage/particles/render.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"
#include "mirage/visibility/view_cell.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct DemoOptions {
  std::string out = "demo-out";
  std::string size = "1280x720";
  std::string device;
  uint32_t seed = 1;
};

struct DemoScene {
  const char* kind;
  uint64_t sizeParameter; // blocks / grid resolution / subdivisions: small enough for lavapipe
};

// The pipeline on the blob: bake a cluster-LOD asset, verify it, render it GPU-driven at two
// thresholds, and sample progressive blue-noise surfels from it.
bool runPipelineDemo(gpu::Context& ctx, const DemoOptions& o, uint32_t width, uint32_t height) {
  namespace fs = std::filesystem;
  auto scene = io::generateScene("blob", o.seed, 7); // 328 k triangles: quick on a CPU Vulkan driver
  if (!scene) return fail(scene.error()), false;
  auto t0 = std::chrono::steady_clock::now();
  auto baked = lod::bakeLodAsset(*scene, {});
  if (!baked) return fail(baked.error()), false;
  fs::path mrg = fs::path(o.out) / "blob-lod.mrg";
  if (auto s = lod::saveLodAsset(mrg.string(), *baked); !s) return fail(s.error()), false;
  const lod::ClusterDag& dag = baked->dags[0];
  fmt::print("  lod      {:>10} triangles -> {} clusters in {} levels, root {} triangles, {:.2f} s -> {}\n",
             dag.inputTriangles, dag.clusters.size(), dag.levelCount(), dag.rootTriangles(), secondsSince(t0),
             mrg.string());
  auto loaded = lod::loadLodAsset(mrg.string());
  if (!loaded) return fail(loaded.error()), false;
  if (Status s = lod::verifyDag(loaded->dags[0]); !s) return fail(s.error()), false;
  Mesh reference = lod::levelZeroMesh(loaded->dags[0]);
  for (float tau : {0.0f, 1e-3f, 1e-2f}) {
    if (Status s = lod::verifyCut(loaded->dags[0], lod::selectCut(loaded->dags[0], tau), reference); !s)
      return fail(s.error()), false;
  }
  fmt::print("           verified: DAG valid, cuts watertight and overlap-free\n");

  auto renderer = render::ClusterRenderer::create(ctx, *loaded);
  if (!renderer) return fail(renderer.error()), false;
  for (float tau : {1.0f, 16.0f}) {
    render::ClusterRenderSettings rs;
    rs.base.width = width;
    rs.base.height = height;
    rs.base.camera = render::autoCamera((*renderer)->worldBounds(), float(width) / float(height));
    rs.tauPixels = tau;
    auto out = (*renderer)->render(rs);
    if (!out) return fail(out.error()), false;
    fs::path png = fs::path(o.out) / fmt::format("blob-lod-tau{}.png", int(tau));
    if (auto s = io::writePng(png, out->image.srgb); !s) return fail(s.error()), false;
    fmt::print("           rendered tau {:>2} px with {} backend: {} clusters, {} triangles -> {}\n", tau,
               render::toString(out->stats.raster), out->stats.clustersSelected, out->stats.trianglesRasterized,
               png.string());
  }

  surfels::CaptureConfig cc;
  cc.resolution = 256;
  cc.views = 16;
  auto gb = surfels::captureGBuffer(ctx, *scene, cc);
  if (!gb) return fail(gb.error()), false;
  surfels::GpuSamplerConfig sc;
  sc.count = 8000; // seconds on a CPU Vulkan driver; `mirage surfels` samples 100 k
  t0 = std::chrono::steady_clock::now();
  auto sampled = surfels::sampleOnGpu(ctx, *gb, sc);
  if (!sampled) return fail(sampled.error()), false;
  surfels::SurfelCloud cloud = surfels::buildSurfelCloud(gb->texels, sampled->order);
  fs::path ply = fs::path(o.out) / "blob-surfels.ply";
  if (auto s = surfels::writeSurfelPly(ply.string(), cloud); !s) return fail(s.error()), false;
  surfels::PrefixQuality q = surfels::measurePrefix(gb->texels, sampled->order, uint32_t(cloud.size()));
  fmt::print(
      "  surfels  {:>10} blue-noise surfels in {:.2f} s, normalized Poisson radius {:.3f}, coverage {:.4f} -> {}\n",
      cloud.size(), secondsSince(t0), q.rho, q.coverage, ply.string());
  return true;
}

// Visibility on the city: GVS++ potentially visible sets for a 2 x 2 grid of street-level cells.
bool runVisibilityDemo(const DemoOptions& o) {
  namespace fs = std::filesystem;
  auto scene = io::generateScene("city", o.seed, 0);
  if (!scene) return fail(scene.error()), false;
  auto backend = vis::createEmbreeBackend(*scene);
  if (!backend) return fail(backend.error()), false;
  Bounds region;
  Bounds b = scene->worldBounds();
  region.add({b.min.x * 0.6f, b.min.y + 1.0f, b.min.z * 0.6f});
  region.add({b.max.x * 0.6f, b.min.y + 3.0f, b.max.z * 0.6f});
  auto cells = vis::gridCells(region, {2, 1, 2});
  if (!cells) return fail(cells.error()), false;
  vis::GvsConfig config;
  config.randomRays = 100000; // a CPU ray tracer; `mirage pvs` defaults to the seed's 10 M
  config.rayBudget = 600000;
  vis::PvsData pvs;
  pvs.cells = *cells;
  pvs.sceneTriangles = scene->instancedTriangleCount();
  auto t0 = std::chrono::steady_clock::now();
  uint64_t rays = 0;
  for (const vis::ViewCell& cell : *cells) {
    vis::CellPvs cellPvs = vis::computeCellPvs(**backend, *scene, cell, config);
    rays += cellPvs.stats.rays;
    pvs.triangles.push_back(std::move(cellPvs.triangles));
  }
  double seconds = secondsSince(t0);
  fs::path out = fs::path(o.out) / "city-pvs.mrg";
  if (auto s = vis::savePvs(out.string(), pvs, scene->source); !s) return fail(s.error()), false;
  size_t smallest = SIZE_MAX, largest = 0;
  for (const auto& t : pvs.triangles) smallest = std::min(smallest, t.size()), largest = std::max(largest, t.size());
  fmt::print("  pvs      {:>10} triangles, {} cells: {}..{} potentially visible ({:.0f}%..{:.0f}%), {:.1f} M rays in "
             "{:.2f} s -> {}\n",
             pvs.sceneTriangles, pvs.cells.size(), smallest, largest,
             100.0 * double(smallest) / double(pvs.sceneTriangles),
             100.0 * double(largest) / double(pvs.sceneTriangles), double(rays) * 1e-6, seconds, out.string());
  return true;
}

// The example particle effects (embedded examples/particles/*.toml) over a generated ground, at
// most 640 pixels wide: quick on lavapipe too.
bool runParticleDemo(gpu::Context& ctx, const DemoOptions& o, uint32_t width, uint32_t height) {
  for (const ExampleEffect& e : kExampleEffects) {
    auto effect = particles::parseEffectFile(e.text, fmt::format("examples/particles/{}.toml", e.name));
    if (!effect) return fail(effect.error()), false;
    particles::ParticleRenderRequest r;
    r.output = (std::filesystem::path(o.out) / fmt::format("particles_{}.png", e.name)).string();
    r.frames = 90;
    r.width = std::min(width, 640u);
    r.height = std::max(1u, uint32_t(uint64_t(r.width) * height / width));
    auto report = particles::renderParticles(ctx, *effect, r);
    if (!report) return fail(report.error()), false;
    fmt::print("  particles {:<6} {:>6} live after {} steps, msl {:.2f} -> {}\n", e.name, report->live, r.frames,
               report->oit.msl, r.output);
  }
  return true;
}

void runDemo(const DemoOptions& o) {
  uint32_t width = 0, height = 0;
  if (auto s = parseSize(o.size, width, height); !s) return fail(s.error());
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec || !std::filesystem::is_directory(o.out)) return fail(makeError(o.out, "cannot create the output folder"));

  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  fmt::print("mirage demo on {} ({}x{}), output in {}/\n", (*ctx)->caps().name, width, height, o.out);

  const DemoScene scenes[] = {{"city", 0}, {"terrain", 0}, {"blob", 0}};
  for (const DemoScene& d : scenes) {
    auto t0 = std::chrono::steady_clock::now();
    auto scene = io::generateScene(d.kind, o.seed, d.sizeParameter);
    if (!scene) return fail(scene.error());
    double genSeconds = secondsSince(t0);
    std::filesystem::path glb = std::filesystem::path(o.out) / fmt::format("{}.glb", d.kind);
    if (auto s = io::writeGlb(*scene, glb); !s) return fail(s.error());
    fmt::print("  {:<8} {:>10} triangles, {:>5} instances, generated in {:.2f} s -> {}\n", d.kind,
               scene->instancedTriangleCount(), scene->instances.size(), genSeconds, glb.string());

    auto renderer = render::ForwardRenderer::create(**ctx, *scene);
    if (!renderer) return fail(renderer.error());
    Bounds b = scene->worldBounds();
    float aspect = float(width) / float(height);
    render::Camera overview = render::autoCamera(b, aspect);
    // A second, closer and lower view from the other side.
    render::Camera close = overview;
    glm::vec3 c = b.center();
    float r = b.radius();
    close.eye = c + glm::vec3(-0.55f * r, 0.28f * r, -0.65f * r);
    close.target = c - glm::vec3(0.0f, 0.15f * r, 0.0f);
    close.znear = close.zfar = 0.0f;
    const std::pair<const char*, render::Camera> views[] = {{"overview", overview}, {"close", close}};
    for (const auto& [name, cam] : views) {
      render::RenderSettings rs;
      rs.width = width;
      rs.height = height;
      rs.camera = cam;
      auto out = (*renderer)->render(rs);
      if (!out) return fail(out.error());
      std::filesystem::path png = std::filesystem::path(o.out) / fmt::format("{}-{}.png", d.kind, name);
      if (auto s = io::writePng(png, out->srgb); !s) return fail(s.error());
      double gpuMs = out->stats.passTimes.empty() ? 0.0 : out->stats.passTimes[0].milliseconds;
      fmt::print("           rendered {:<8} in {:8.2f} ms GPU -> {}\n", name, gpuMs, png.string());
    }
  }
  if (!runParticleDemo(**ctx, o, width, height)) return;
  if (!runPipelineDemo(**ctx, o, width, height)) return;
  if (!runVisibilityDemo(o)) return;
  fmt::print("done: open the PNGs in {}/, or render a GLB yourself: mirage render {}/city.glb -o city.png --stats\n",
             o.out, o.out);
}

} // namespace

void addDemoCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "Generate procedural scenes, render them, and say where the images are");
  auto o = std::make_shared<DemoOptions>();
  cmd->add_option("--out", o->out, "Output folder (created if missing)")->capture_default_str();
  cmd->add_option("--size", o->size, "WxH of the rendered views")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the generated scenes")->capture_default_str();
  cmd->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->callback([o] { runDemo(*o); });
}

} // namespace mirage::cli
