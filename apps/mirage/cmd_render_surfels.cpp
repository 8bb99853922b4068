// mirage bench surfels: the surfel renderer on a .mrg 'SURF' chunk (from `mirage surfels INPUT -o
// FILE.mrg`) or a surfel PLY, as copies on a grid, splat orders and variants timed in one run
// (`mirage render FILE --surfels` goes through runtime::Scene, cmd_render.cpp).
#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/io/image_io.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/runtime/config.h"
#include "mirage/runtime/scene_argument.h"
#include "mirage/surfels/surfel_io.h"
#include "render_common.h"
#include "render_options.h"
#include "surfel_render.h"

namespace mirage::cli {

namespace {

struct SurfelSession {
  surfels::SurfelCloud cloud;
  Material material;
  std::unique_ptr<gpu::Context> ctx;
  std::vector<std::unique_ptr<render::SurfelRenderer>> renderers; // one per splat order, same scene
  render::SurfelRenderSettings settings;
};

// `copies` of the cloud on a square grid on the ground plane, spaced by 1.25x its largest
// horizontal extent (how the benchmark reaches 100M+ surfels from one sampled cloud). Each copy gets
// its own copy of the data unless `shared`: one small cloud read by every instance stays in the L2
// cache, which would measure cache, not memory, bandwidth.
render::SurfelScene gridScene(const SurfelSession& s, uint32_t copies, bool shared) {
  render::SurfelScene scene;
  for (uint32_t i = 0; i < (shared ? 1u : copies); ++i) scene.clouds.push_back({&s.cloud, s.material});
  uint32_t side = uint32_t(std::ceil(std::sqrt(double(copies))));
  glm::vec3 e = s.cloud.box.extent();
  float spacing = 1.25f * std::max(e.x, e.z);
  for (uint32_t i = 0; i < copies; ++i) {
    glm::vec3 offset{(float(i % side) - 0.5f * float(side - 1)) * spacing, 0.0f,
                     (float(i / side) - 0.5f * float(side - 1)) * spacing};
    glm::mat4 t(1.0f);
    t[3] = glm::vec4(offset, 1.0f);
    scene.instances.push_back({shared ? 0u : i, t});
  }
  return scene;
}

// One order ("blue", "coherent", "coherent256"), or (bench) a comma-separated list or "all" (every
// order, compared in one run; the first is the baseline). `flag` names the option in errors.
Result<std::vector<render::SurfelOrder>> parseOrders(const std::string& text, const char* flag, bool allowList) {
  std::vector<render::SurfelOrder> out;
  if (allowList && text == "all")
    return std::vector{render::SurfelOrder::Blue, render::SurfelOrder::Coherent, render::SurfelOrder::Coherent256};
  for (size_t start = 0; start <= text.size();) {
    size_t end = allowList ? std::min(text.find(',', start), text.size()) : text.size();
    auto o = render::parseSurfelOrder(std::string_view(text).substr(start, end - start));
    if (!o || std::find(out.begin(), out.end(), *o) != out.end())
      return Error{fmt::format("{} '{}': expected {}blue, coherent or coherent256{}", flag, text,
                               allowList ? "a list of distinct " : "", allowList ? ", or all" : "")};
    out.push_back(*o);
    start = end + 1;
  }
  return out;
}

// Checks the arguments, loads the cloud, starts the GPU, uploads the scene once per order. Returns
// false after fail().
bool open(const SurfelRenderRequest& r, const std::vector<render::SurfelOrder>& orders, SurfelSession& s) {
  uint32_t width = 0, height = 0;
  if (auto st = parseSize(r.size, width, height); !st) return fail(st.error()), false;
  runtime::RenderConfig config; // the range of --surfel-size, checked where the runtime checks it
  config.surfelSize = r.surfelSize;
  if (auto st = runtime::validate(config); !st) return fail(st.error()), false;
  if (r.copies < 1 || r.copies > 65536) return fail("--copies must be in 1..65536"), false;
  render::Camera camera;
  if (!r.camera.empty()) {
    auto c = render::parseCamera(r.camera);
    if (!c) return fail(c.error()), false;
    camera = *c;
  }
  auto cloud = runtime::loadSurfelCloud(r.input, s.material);
  if (!cloud) return fail(cloud.error()), false;
  s.cloud = std::move(*cloud);
  if (!r.sharedCopies && uint64_t(r.copies) * s.cloud.size() > 0xfffffffeull)
    return fail(fmt::format("--copies {} x {} surfels exceeds 2^32 - 2 stored surfels (use --shared-copies)", r.copies,
                            s.cloud.size())),
           false;
  auto ctx = openDevice(r.device);
  if (!ctx) return fail(ctx.error()), false;
  s.ctx = std::move(*ctx);
  render::SurfelScene scene = gridScene(s, r.copies, r.sharedCopies);
  for (render::SurfelOrder order : orders) {
    auto renderer = render::SurfelRenderer::create(*s.ctx, scene, order);
    if (!renderer) return fail(renderer.error()), false;
    s.renderers.push_back(std::move(*renderer));
  }
  s.settings.base.width = width;
  s.settings.base.height = height;
  s.settings.base.camera =
      r.camera.empty() ? render::autoCamera(s.renderers[0]->worldBounds(), float(width) / float(height)) : camera;
  s.settings.surfelSize = r.surfelSize;
  s.settings.allSurfels = r.allSurfels;
  s.settings.stereoIpd = r.stereoIpd;
  return true;
}

struct SurfelTimed {
  std::vector<gpu::PassTime> times; // medians over the timed frames
  render::SurfelRenderOutput last;
  size_t frames = 0;
};

// `frames` frames of every renderer (same settings, same view), interleaved frame by frame so a
// clock or thermal drift during the run affects every order alike; out[i] for renderer i. Before
// them, untimed frames of the first renderer for `warmupMs` (the GPU's clock, kBenchWarmupMs).
bool renderFrames(SurfelSession& s, int frames, std::vector<SurfelTimed>& out, double warmupMs = 0.0) {
  size_t n = s.renderers.size();
  std::vector<std::vector<std::vector<gpu::PassTime>>> all(n);
  out.assign(n, SurfelTimed{});
  for (auto start = std::chrono::steady_clock::now();
       n > 0 && std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() < warmupMs;)
    if (auto o = s.renderers[0]->render(s.settings); !o) return fail(o.error()), false;
  for (int i = 0; i < frames; ++i)
    for (size_t r = 0; r < n; ++r) {
      auto o = s.renderers[r]->render(s.settings);
      if (!o) return fail(o.error()), false;
      all[r].push_back(o->image.stats.passTimes);
      out[r].last = std::move(*o);
    }
  for (size_t r = 0; r < n; ++r) {
    if (all[r].size() > 1) all[r].erase(all[r].begin()); // pipeline warm-up
    out[r].frames = all[r].size();
    out[r].times = medianPassTimes(all[r]);
  }
  return true;
}

// CPU estimate of the splat's visibility-buffer locality: for up to 16 instances spread over the
// grid, the surfels each draws (its k from `states`), projected as the splat does, grouped as one
// 32-lane warp reads them (32 consecutive stored surfels); the mean number of distinct 128-byte
// lines (16 pixels of 8 bytes, row-major) and distinct pixels per warp over warps with a pixel on
// screen. What the coherent order is for: the blue-noise order touches ~32 lines per warp.
struct WarpLocality {
  double lines = 0.0, pixels = 0.0;
  size_t warps = 0;
};
WarpLocality warpLocality(const SurfelSession& s, const render::SurfelScene& scene, render::SurfelOrder order,
                          const std::vector<uint32_t>& prefix) {
  const auto& base = s.settings.base;
  render::Camera cam = render::withClipPlanes(base.camera, s.renderers[0]->worldBounds());
  glm::mat4 viewProj = cam.projection(float(base.width) / float(base.height)) * cam.view();
  std::vector<uint32_t> at = order == render::SurfelOrder::Blue
                                 ? std::vector<uint32_t>{}
                                 : render::coherentSurfelOrder(s.cloud, render::coherentMinBlock(order));
  WarpLocality w;
  size_t step = std::max<size_t>(1, scene.instances.size() / 16);
  for (size_t inst = 0; inst < scene.instances.size() && inst < prefix.size(); inst += step) {
    glm::mat4 m = viewProj * scene.instances[inst].transform;
    for (uint32_t first = 0; first < prefix[inst]; first += 32) {
      std::vector<uint32_t> lines, pixels;
      for (uint32_t i = first; i < std::min(first + 32, prefix[inst]); ++i) {
        glm::vec3 p = surfels::surfelPosition(s.cloud.box, s.cloud.surfels[at.empty() ? i : at[i]]);
        glm::vec4 clip = m * glm::vec4(p, 1.0f);
        if (clip.w <= 0.0f) continue;
        glm::vec2 px = (glm::vec2(clip) / clip.w * 0.5f + 0.5f) * glm::vec2(base.width, base.height);
        if (px.x < 0.0f || px.y < 0.0f || px.x >= float(base.width) || px.y >= float(base.height)) continue;
        uint32_t pixel = uint32_t(px.y) * base.width + uint32_t(px.x);
        pixels.push_back(pixel);
        lines.push_back(pixel / 16);
      }
      if (pixels.empty()) continue;
      for (auto* v : {&lines, &pixels}) {
        std::sort(v->begin(), v->end());
        v->erase(std::unique(v->begin(), v->end()), v->end());
      }
      w.lines += double(lines.size());
      w.pixels += double(pixels.size());
      ++w.warps;
    }
  }
  if (w.warps) w.lines /= double(w.warps), w.pixels /= double(w.warps);
  return w;
}

double passMs(const std::vector<gpu::PassTime>& times, const std::string& name) {
  for (const auto& t : times)
    if (t.name == name) return t.milliseconds;
  return 0.0;
}

} // namespace

void runSurfelBench(const SurfelRenderRequest& r) {
  if (r.frames < 2 || r.frames > 100000) return fail("--frames must be in 2..100000");
  if (!(r.bandwidth > 0.0)) return fail("--bandwidth must be positive (bytes per second)");
  std::vector<render::SurfelRaster> rasters;
  if (r.raster != "all") {
    auto b = render::parseSurfelRaster(r.raster);
    if (!b) return fail(b.error());
    rasters.push_back(*b);
  }
  std::vector<bool> cullings;
  if (r.backface == "on" || r.backface == "both") cullings.push_back(true);
  if (r.backface == "off" || r.backface == "both") cullings.push_back(false);
  if (cullings.empty()) return fail("--backface must be on, off or both (got " + r.backface + ")");
  std::vector<render::SurfelMerge> merges;
  if (r.merge == "both" || r.merge == "all") {
    merges = {render::SurfelMerge::Off, render::SurfelMerge::On};
    if (r.merge == "all") merges.push_back(render::SurfelMerge::Auto);
  } else {
    auto m = render::parseSurfelMerge(r.merge);
    if (!m) return fail(m.error().message + " (or both, all)");
    merges.push_back(*m);
  }
  std::vector<bool> orientations; // oriented discs
  if (r.discs == "oriented" || r.discs == "both") orientations.push_back(true);
  if (r.discs == "facing" || r.discs == "both") orientations.push_back(false);
  if (orientations.empty()) return fail("--discs must be oriented, facing or both (got " + r.discs + ")");
  auto orders = parseOrders(r.order, "--order", /*allowList=*/true);
  if (!orders) return fail(orders.error());
  SurfelSession s;
  if (!open(r, *orders, s)) return;
  s.settings.base.readImage = false; // no CPU gaps between timed frames (they lower the GPU clock)
  const auto& caps = s.ctx->caps();
  if (rasters.empty()) { // --stereo: the raster fallback has no stereo (the renderer says so if asked)
    if (caps.int64BufferAtomics) rasters.push_back(render::SurfelRaster::Compute);
    if (!r.stereoIpd || rasters.empty()) rasters.push_back(render::SurfelRaster::Raster);
  }
  // Before the header: a stereo frame the renderer refuses fails with its one line and nothing else.
  if (r.stereoIpd) {
    render::SurfelRenderSettings probe = s.settings;
    probe.raster = rasters[0];
    if (auto o = s.renderers[0]->render(probe); !o) return fail(o.error());
  }
  if (!r.json)
    fmt::print("bench surfels {} on {}: {} surfels stored, {} copies ({} instanced) at {}x{}{}, surfel size {} px, {}; "
               "{} timed frames per order (orders interleaved frame by frame); bandwidth {:.3g} B/s\n",
               r.input, caps.name, s.renderers[0]->surfelCount(), r.copies, s.renderers[0]->instancedCount(),
               s.settings.base.width, s.settings.base.height,
               r.stereoIpd ? fmt::format(" per eye (stereo, ipd {}: both eyes, one prefix selection)", *r.stereoIpd)
                           : "",
               r.surfelSize, r.allSurfels ? "all surfels (no prefix)" : "adaptive prefix", r.frames - 1, r.bandwidth);
  nlohmann::json all = nlohmann::json::array();
  for (render::SurfelRaster raster : rasters)
    for (bool cull : cullings)
      for (render::SurfelMerge merge : merges)
        for (bool oriented : orientations) {
          // A compute splat variant: the raster fallback runs once, under the first merge choice.
          if (raster != render::SurfelRaster::Compute && merge != merges[0]) continue;
          s.settings.raster = raster;
          s.settings.backfaceCulling = cull;
          s.settings.merge = merge;
          s.settings.orientedDiscs = oriented;
          std::vector<SurfelTimed> timed;
          if (!renderFrames(s, r.frames, timed, r.warmupMs)) return;
          double baseSplatMs = 0.0, baseFrameMs = 0.0;
          for (size_t o = 0; o < timed.size(); ++o) {
            const SurfelTimed& t = timed[o];
            const char* order = render::toString((*orders)[o]);
            double splatMs = passMs(t.times, "splat"), frameMs = passMs(t.times, "frame");
            double surfels = double(t.last.surfelsSplatted);
            double perSecond = splatMs > 0.0 ? surfels / (splatMs * 1e-3) : 0.0;
            // The splat streams the 8-byte quantized positions, and with back-face culling the 8-byte
            // attributes (normal + colour, one sector) too; the resolve reads attributes of visible pixels.
            double bytesPerSecond = perSecond * (cull ? 16.0 : 8.0);
            // The first order is the baseline: the coherent order's rounded-up prefixes splat more
            // surfels, so its frame and splat times compare, not only its surfels/s.
            if (o == 0) baseSplatMs = splatMs, baseFrameMs = frameMs;
            double splatSpeedup = splatMs > 0.0 ? baseSplatMs / splatMs : 0.0;
            double frameSpeedup = frameMs > 0.0 ? baseFrameMs / frameMs : 0.0;
            if (r.json) {
              nlohmann::json j = {{"raster", render::toString(raster)},
                                  {"order", order},
                                  {"backface_culling", cull},
                                  {"subgroup_merge", render::toString(merge)},
                                  {"oriented_discs", oriented},
                                  {"instances_merged", t.last.mergedInstances},
                                  {"surfels_splatted", t.last.surfelsSplatted},
                                  {"instances_visible", t.last.visibleInstances},
                                  {"surfels_per_second", perSecond},
                                  {"bytes_per_second", bytesPerSecond},
                                  {"bandwidth_fraction", bytesPerSecond / r.bandwidth},
                                  {"splat_speedup_vs_first_order", splatSpeedup},
                                  {"frame_speedup_vs_first_order", frameSpeedup}};
              for (const auto& p : t.times) j["gpu_ms"][p.name] = p.milliseconds;
              all.push_back(j);
              continue;
            }
            fmt::print("-- {}, subgroup merge {}, {} discs, {} order, back-face culling {}: instances visible {} "
                       "(merged {}), surfels splatted {}\n",
                       render::toString(raster), render::toString(merge), oriented ? "oriented" : "facing", order,
                       cull ? "on" : "off", t.last.visibleInstances, t.last.mergedInstances, t.last.surfelsSplatted);
            for (const auto& p : t.times) fmt::print("gpu {:<8} {:9.3f} ms (median)\n", p.name, p.milliseconds);
            fmt::print("splat {:.4g} G surfels/s, {:.4g} GB/s of surfel positions read = {:.3g}% of {:.3g} B/s\n",
                       perSecond * 1e-9, bytesPerSecond * 1e-9, 100.0 * bytesPerSecond / r.bandwidth, r.bandwidth);
            if (o > 0)
              fmt::print("{} vs {} order: speedup x{:.3f} splat, x{:.3f} frame ({} time / {} time)\n", order,
                         render::toString((*orders)[0]), splatSpeedup, frameSpeedup, render::toString((*orders)[0]),
                         order);
          }
        }
  // After the timed frames: one frame per order with its instance states read back, for the CPU
  // estimate of how many visibility-buffer lines a warp touches (the quantity the order changes).
  nlohmann::json locality = nlohmann::json::object();
  render::SurfelScene scene = gridScene(s, r.copies, r.sharedCopies);
  for (size_t o = 0; o < orders->size(); ++o) {
    render::SurfelRenderSettings probe = s.settings;
    probe.readInstanceStates = true;
    auto out = s.renderers[o]->render(probe);
    if (!out) return fail(out.error());
    WarpLocality w = warpLocality(s, scene, (*orders)[o], out->prefix);
    const char* order = render::toString((*orders)[o]);
    locality[order] = {{"lines_per_warp", w.lines}, {"pixels_per_warp", w.pixels}, {"warps", w.warps}};
    if (!r.json)
      fmt::print("{} order: a 32-surfel warp touches {:.1f} visibility-buffer lines of 128 B, {:.1f} pixels (CPU "
                 "estimate, {} warps of up to 16 instances)\n",
                 order, w.lines, w.pixels, w.warps);
  }
  if (r.json) {
    nlohmann::json j = {{"bench", "surfels"},
                        {"input", r.input},
                        {"device", caps.name},
                        {"surfels", s.renderers[0]->surfelCount()},
                        {"copies", r.copies},
                        {"shared_copies", r.sharedCopies},
                        {"instanced_surfels", s.renderers[0]->instancedCount()},
                        {"surfel_size", r.surfelSize},
                        {"all_surfels", r.allSurfels},
                        {"bandwidth", r.bandwidth},
                        {"width", s.settings.base.width},
                        {"height", s.settings.base.height},
                        {"stereo_ipd", r.stereoIpd ? nlohmann::json(*r.stereoIpd) : nlohmann::json()},
                        {"rasters", all},
                        {"warp_locality", locality}};
    fmt::print("{}\n", j.dump(2));
  }
}

void addBenchSurfelsCommand(CLI::App& bench) {
  auto* b =
      bench.add_subcommand("surfels", "Surfel splatting: per-stage GPU times, surfels/s, bytes/s, bandwidth share");
  auto o = std::make_shared<SurfelRenderRequest>();
  o->frames = 20;
  o->raster = "all";
  b->add_option("input", o->input, ".mrg with a SURF chunk, or a surfel .ply")->required();
  b->add_option("--size", o->size, "WxH")->capture_default_str();
  b->add_option("--frames", o->frames, "Frames (the first is a warm-up)")->capture_default_str();
  o->warmupMs = kBenchWarmupMs;
  b->add_option("--warmup-ms", o->warmupMs,
                "Untimed frames first for this long (an idle GPU's clock may not rise for short frames alone)")
      ->check(CLI::Range(0.0, 60000.0))
      ->capture_default_str();
  b->add_option("--copies", o->copies, "Instances of the cloud on a square grid")->capture_default_str();
  b->add_option("--surfel-size", o->surfelSize, "Surfel diameter in pixels")->capture_default_str();
  b->add_option("--surfel-raster", o->raster, "all|compute|raster")->capture_default_str();
  b->add_flag("--shared-copies", o->sharedCopies,
              "All copies read one stored cloud (cache-resident; default: one each)");
  b->add_flag("--all", o->allSurfels, "Splat every surfel of every instance (no prefix): raw throughput");
  o->order = "all";
  b->add_option("--order", o->order,
                "Splat orders of the uploaded clouds, timed in one run with frames interleaved (the first is the "
                "baseline): all, or a comma list of blue|coherent|coherent256")
      ->capture_default_str();
  b->add_option("--backface", o->backface,
                "Back-face culling of single-sided clouds: on|off|both (both: timed in one run)")
      ->capture_default_str();
  b->add_option("--merge", o->merge,
                "Compute splat variant: subgroup lanes hitting one pixel merge before the atomic: off|on|auto (per "
                "instance: where surfels are dense on screen), both (off, on) or all (off, on, auto) timed in one run")
      ->capture_default_str();
  b->add_option("--discs", o->discs,
                "Disc shape: oriented (in the tangent plane, ellipses on screen), facing (screen circles) or both")
      ->capture_default_str();
  b->add_option("--bandwidth", o->bandwidth, "Device memory bandwidth in B/s (H200 HBM3e: 4.8e12)")
      ->capture_default_str();
  b->add_option("--camera", o->camera, "eye=x,y,z,target=x,y,z[,fov=60]; default: auto 3/4 view of all copies");
  b->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  b->add_flag("--json", o->json, "Print results as JSON");
  auto stereo = std::make_shared<StereoOptions>();
  bindStereo(*b, *stereo);
  b->callback([o, stereo] {
    o->stereoIpd = stereo->ipdOrNone();
    runSurfelBench(*o);
  });
}

} // namespace mirage::cli
