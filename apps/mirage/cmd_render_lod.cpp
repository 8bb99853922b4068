// mirage render / bench render on .mrg assets through the cluster-LOD renderer.
#include <algorithm>
#include <chrono>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "lod_render.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct Session {
  std::unique_ptr<gpu::Context> ctx;
  lod::LodAsset asset;
  std::unique_ptr<render::ClusterRenderer> renderer;
  render::ClusterRenderSettings settings;
  double loadSeconds = 0.0;
};

// "on" / "off" (and "both" where allowed) of a culling option; false after fail().
bool parseSwitch(const std::string& value, const char* option, bool allowBoth) {
  if (value == "on" || value == "off" || (allowBoth && value == "both")) return true;
  fail(fmt::format("{} '{}': expected on, off{}", option, value, allowBoth ? " or both" : ""));
  return false;
}

// Checks the arguments, loads the asset, starts the GPU. Returns false after fail().
bool open(const LodRenderRequest& r, bool needOutput, Session& s) {
  uint32_t width = 0, height = 0;
  if (auto st = parseSize(r.size, width, height); !st) return fail(st.error()), false;
  if (needOutput) {
    if (auto st = checkOutputPath(r.output, {".png"}); !st) return fail(st.error()), false;
    if (!r.exr.empty())
      if (auto st = checkOutputPath(r.exr, {".exr", ".pfm"}); !st) return fail(st.error()), false;
  }
  if (!(r.tau > 0.0f) || r.tau > 1e6f) return fail("--tau must be a positive number of pixels"), false;
  if (!(r.cull.hybridThreshold >= 0.0f) || r.cull.hybridThreshold > 1e6f)
    return fail("--hybrid-threshold must be a number of pixels in 0..1e6"), false;
  if (!parseSwitch(r.cull.occlusion, "--occlusion", /*allowBoth=*/!needOutput)) return false;
  if (!parseSwitch(r.cull.cones, "--cones", /*allowBoth=*/false)) return false;
  render::Camera camera;
  if (!r.camera.empty()) {
    auto c = render::parseCamera(r.camera);
    if (!c) return fail(c.error()), false;
    camera = *c;
  }
  auto t0 = std::chrono::steady_clock::now();
  auto asset = lod::loadLodAsset(r.input);
  if (!asset) return fail(asset.error()), false;
  s.asset = std::move(*asset);
  if (r.grid < 1 || r.grid > 256) return fail("--grid must be in 1..256"), false;
  if (r.grid > 1) {
    // The seed's benchmark scenes: copies of the scene on a square grid on the ground plane,
    // spaced by 1.25x the scene's largest horizontal extent.
    Bounds b = s.asset.scene.worldBounds();
    float spacing = 1.25f * std::max(b.extent().x, b.extent().z);
    std::vector<Instance> original = s.asset.scene.instances, grid;
    for (uint32_t gz = 0; gz < r.grid; ++gz)
      for (uint32_t gx = 0; gx < r.grid; ++gx)
        for (Instance inst : original) {
          glm::vec3 offset{(float(gx) - 0.5f * float(r.grid - 1)) * spacing, 0.0f,
                           (float(gz) - 0.5f * float(r.grid - 1)) * spacing};
          inst.transform[3] += glm::vec4(offset, 0.0f);
          grid.push_back(inst);
        }
    s.asset.scene.instances = std::move(grid);
  }
  s.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto ctx = openDevice(r.device);
  if (!ctx) return fail(ctx.error()), false;
  s.ctx = std::move(*ctx);
  auto renderer = render::ClusterRenderer::create(*s.ctx, s.asset);
  if (!renderer) return fail(renderer.error()), false;
  s.renderer = std::move(*renderer);
  s.settings.base.width = width;
  s.settings.base.height = height;
  s.settings.base.camera =
      r.camera.empty() ? render::autoCamera(s.renderer->worldBounds(), float(width) / float(height)) : camera;
  s.settings.base.readLinear = !r.exr.empty();
  s.settings.tauPixels = r.tau;
  s.settings.hybridThreshold = r.cull.hybridThreshold;
  s.settings.occlusionCulling = r.cull.occlusion != "off";
  s.settings.coneCulling = r.cull.cones == "on";
  return true;
}

struct Timed {
  std::vector<gpu::PassTime> times; // medians over the timed frames
  render::ClusterRenderOutput last;
  size_t frames = 0;
};

// Renders `frames` frames; with more than one, the first (pipeline warm-up) is not timed.
bool renderFrames(Session& s, int frames, Timed& out) {
  std::vector<std::vector<gpu::PassTime>> all;
  for (int i = 0; i < frames; ++i) {
    auto o = s.renderer->render(s.settings);
    if (!o) return fail(o.error()), false;
    all.push_back(o->image.stats.passTimes);
    out.last = std::move(*o);
  }
  if (all.size() > 1) all.erase(all.begin());
  out.frames = all.size();
  out.times = medianPassTimes(all);
  return true;
}

nlohmann::json statsJson(const render::ClusterStats& st) {
  return {{"raster", render::toString(st.raster)},
          {"occlusion", st.occlusion},
          {"instances_visible", st.instancesVisible},
          {"clusters_tested", st.clustersTested},
          {"clusters_selected", st.clustersSelected},
          {"clusters_frustum_culled", st.clustersFrustumCulled},
          {"clusters_backface_culled", st.clustersBackfaceCulled},
          {"clusters_pass1", st.clustersPass1},
          {"clusters_occlusion_tested", st.clustersOcclusionTested},
          {"clusters_occlusion_culled", st.clustersOcclusionCulled},
          {"instances_late", st.instancesLate},
          {"instances_occlusion_culled", st.instancesOcclusionCulled},
          {"history_kept", st.historyKept},
          {"clusters_drawn", st.clustersDrawn},
          {"clusters_hardware", st.clustersHardware},
          {"triangles_near_clipped", st.trianglesNearClipped},
          {"clusters_overflow", st.clustersOverflow},
          {"triangles_rasterized", st.trianglesRasterized}};
}

void printStats(const render::ClusterStats& st, const std::vector<gpu::PassTime>& times, bool median) {
  fmt::print("raster {}  instances visible {}  clusters tested {}  selected {}  frustum-culled {}  cone-culled {}{}\n",
             render::toString(st.raster), st.instancesVisible, st.clustersTested, st.clustersSelected,
             st.clustersFrustumCulled, st.clustersBackfaceCulled,
             st.clustersOverflow ? fmt::format("  OVERFLOW {}", st.clustersOverflow) : "");
  if (st.occlusion)
    fmt::print("occlusion: pass 1 drew {} clusters (visible last frame); pass 2 tested {} instances, culled {}, "
               "tested {} clusters, culled {}; {} clusters own pixels\n",
               st.clustersPass1, st.instancesLate, st.instancesOcclusionCulled, st.clustersOcclusionTested,
               st.clustersOcclusionCulled, st.historyKept);
  fmt::print("clusters drawn {} ({} by hardware)  triangles rasterized {}  near-clipped {}\n", st.clustersDrawn,
             st.clustersHardware, st.trianglesRasterized, st.trianglesNearClipped);
  for (const auto& t : times) fmt::print("gpu {:<8} {:9.3f} ms{}\n", t.name, t.milliseconds, median ? " (median)" : "");
}

uint64_t sourceTriangles(const lod::LodAsset& a) {
  uint64_t n = 0;
  for (const Instance& inst : a.scene.instances)
    if (inst.mesh < a.dags.size()) n += a.dags[inst.mesh].inputTriangles;
  return n;
}

} // namespace

void addLodCullOptions(CLI::App& command, LodCullOptions& o, bool bench) {
  command
      .add_option("--hybrid-threshold", o.hybridThreshold,
                  ".mrg, hybrid raster: clusters whose estimated triangle edge reaches this many pixels go to the "
                  "hardware path")
      ->capture_default_str();
  command
      .add_option("--occlusion", o.occlusion,
                  bench ? ".mrg: two-pass HZB occlusion culling on|off|both"
                        : ".mrg: two-pass HZB occlusion culling on|off")
      ->capture_default_str();
  command.add_option("--cones", o.cones, ".mrg: normal-cone back-face culling on|off")->capture_default_str();
}

bool isLodAssetPath(const std::string& input) { return input.size() > 4 && input.ends_with(".mrg"); }

void runLodRender(const LodRenderRequest& r) {
  if (r.frames < 1 || r.frames > 10000) return fail("--repeat must be in 1..10000");
  auto backend = render::parseRasterBackend(r.raster);
  if (!backend) return fail(backend.error());
  Session s;
  if (!open(r, /*needOutput=*/true, s)) return;
  s.settings.raster = *backend;
  Timed t;
  if (!renderFrames(s, r.frames, t)) return;
  if (auto st = io::writePng(r.output, t.last.image.srgb); !st) return fail(st.error());
  if (!r.exr.empty()) {
    auto st =
        r.exr.ends_with(".pfm") ? io::writePfm(r.exr, t.last.image.linear) : io::writeExr(r.exr, t.last.image.linear);
    if (!st) return fail(st.error());
  }
  const auto& caps = s.ctx->caps();
  if (r.json) {
    nlohmann::json j = statsJson(t.last.stats);
    j["input"] = r.input;
    j["output"] = r.output;
    j["device"] = caps.name;
    j["tau_pixels"] = r.tau;
    j["hybrid_threshold"] = r.cull.hybridThreshold;
    j["width"] = s.settings.base.width;
    j["height"] = s.settings.base.height;
    j["source_triangles"] = sourceTriangles(s.asset);
    j["load_seconds"] = s.loadSeconds;
    j["frames_timed"] = t.frames;
    for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} source triangles, {} instances, {} clusters) at {}x{}, tau {} px, on {} -> {}\n", r.input,
             sourceTriangles(s.asset), s.asset.scene.instances.size(), s.renderer->clusterCount(),
             s.settings.base.width, s.settings.base.height, r.tau, caps.name, r.output);
  if (r.stats) {
    fmt::print("load {:.3f} s\n", s.loadSeconds);
    printStats(t.last.stats, t.times, t.frames > 1);
  }
}

void runLodBench(const LodRenderRequest& r) {
  if (r.frames < 2 || r.frames > 100000) return fail("--frames must be in 2..100000");
  std::vector<render::RasterBackend> backends;
  if (r.raster != "all") {
    auto b = render::parseRasterBackend(r.raster);
    if (!b) return fail(b.error());
    backends.push_back(*b);
  }
  Session s;
  if (!open(r, /*needOutput=*/false, s)) return;
  const auto& caps = s.ctx->caps();
  if (backends.empty()) {
    backends.push_back(render::RasterBackend::Indirect);
    if (caps.meshShader) backends.push_back(render::RasterBackend::Mesh);
    if (caps.int64BufferAtomics) backends.push_back(render::RasterBackend::Compute);
    if (caps.int64BufferAtomics && caps.fragmentStoresAndAtomics && caps.meshShader)
      backends.push_back(render::RasterBackend::Hybrid);
  }
  std::vector<bool> occlusionModes;
  if (r.cull.occlusion != "off") occlusionModes.push_back(true);
  if (r.cull.occlusion != "on") occlusionModes.push_back(false);
  nlohmann::json all = nlohmann::json::array();
  if (!r.json)
    fmt::print("bench render {} on {}: {} source triangles, {} instances at {}x{}, tau {} px, hybrid threshold {} "
               "px, cones {}, {} timed frames\n",
               r.input, caps.name, sourceTriangles(s.asset), s.asset.scene.instances.size(), s.settings.base.width,
               s.settings.base.height, r.tau, r.cull.hybridThreshold, r.cull.cones, r.frames - 1);
  for (render::RasterBackend b : backends)
    for (bool occlusion : occlusionModes) {
      s.settings.raster = b;
      s.settings.occlusionCulling = occlusion;
      Timed t; // the untimed warm-up frame fills the occlusion history for this view

      if (!renderFrames(s, r.frames, t)) return;
      if (r.json) {
        nlohmann::json j = statsJson(t.last.stats);
        for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
        all.push_back(j);
        continue;
      }
      fmt::print("-- {}, occlusion {}\n", render::toString(b), occlusion ? "on" : "off");
      printStats(t.last.stats, t.times, true);
    }
  if (r.json) {
    nlohmann::json j = {{"bench", "render_lod"},
                        {"input", r.input},
                        {"device", caps.name},
                        {"tau_pixels", r.tau},
                        {"hybrid_threshold", r.cull.hybridThreshold},
                        {"backends", all},
                        {"width", s.settings.base.width},
                        {"height", s.settings.base.height},
                        {"source_triangles", sourceTriangles(s.asset)}};
    fmt::print("{}\n", j.dump(2));
  }
}

} // namespace mirage::cli
