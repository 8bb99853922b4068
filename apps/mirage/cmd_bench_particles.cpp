// mirage bench particles FX.toml --count N --sim cpu|gpu [--steps S]: particle simulation speed of an
// effect scaled to N particles (mirage/particles/bench.h): ms per step and live particles; with
// --render (GPU) the frame drawing them too (mirage/particles/render.h).
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/gpu/context.h"
#include "mirage/particles/bench.h"
#include "mirage/particles/gpu_simulation.h"
#include "mirage/particles/render.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct BenchParticlesOptions {
  std::string input;
  uint64_t count = 1000000;
  uint32_t steps = 100;
  std::string sim = "cpu";
  std::string device;
  bool json = false;
  bool render = false; // --sim gpu: simulate and draw each frame (particles/render.h)
  std::string size = "1920x1080";
  std::string oit = "linked-list";
  std::string camera;               // --render: empty frames the effect
  bool noSplat = false;             // --render: every particle a billboard
  std::string splatMethod = "auto"; // --render: binned, atomic or auto (binned)
  bool separateOutput = false;      // --render: the render records by their own pass after the step
};

// --render: simulation + billboards over a ground, GPU times per frame.
void runBenchParticlesRender(const BenchParticlesOptions& o, const particles::EffectFile& effect) {
  particles::RenderBenchOptions ro;
  ro.count = o.count;
  ro.frames = o.steps;
  if (auto s = parseSize(o.size, ro.width, ro.height); !s) return fail(s.error());
  auto oit = render::parseOitMode(o.oit);
  if (!oit) return fail(oit.error());
  ro.oit = *oit;
  ro.camera = o.camera;
  ro.splat = !o.noSplat;
  ro.fusedOutput = !o.separateOutput;
  ro.splatMethod = o.splatMethod == "binned"   ? render::SplatMethod::Binned
                   : o.splatMethod == "atomic" ? render::SplatMethod::Atomic
                                               : render::SplatMethod::Auto;
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto r = particles::benchRender(**ctx, effect, ro);
  if (!r) return fail(r.error());
  if (o.json) {
    nlohmann::json j = {{"bench", "particles"},
                        {"input", o.input},
                        {"sim", "gpu"},
                        {"render", true},
                        {"device", (*ctx)->caps().name},
                        {"count", o.count},
                        {"live", r->live},
                        {"frames", o.steps},
                        {"width", ro.width},
                        {"height", ro.height},
                        {"oit", o.oit},
                        {"simulate_ms", r->simulateMs},
                        {"render_ms", r->frameMs},
                        {"blend_ms", r->blendMs},
                        {"composite_ms", r->compositeMs},
                        {"splat", ro.splat},
                        {"splat_method", !ro.splat        ? "none"
                                         : r->splatBinned ? "binned"
                                                          : "atomic"},
                        {"fused_output", ro.fusedOutput},
                        {"splat_ms", r->splatMs},
                        {"splat_resolve_ms", r->splatResolveMs},
                        {"splat_count_ms", r->splatCountMs},
                        {"splat_scan_ms", r->splatScanMs},
                        {"splat_scatter_ms", r->splatScatterMs},
                        {"splat_tiles_ms", r->splatTilesMs},
                        {"billboards", r->billboards},
                        {"total_ms", r->totalMs},
                        {"msl", r->oit.msl},
                        {"oit_dropped", r->oit.dropped()},
                        {"oit_fragments", r->oit.fragments}};
    for (const auto& [name, ms] : r->passMs) j["gpu_ms"][name] = ms;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench particles {} --render on {}: {} live particles ({} asked), {}x{}, {}, {} timed frames\n", o.input,
             (*ctx)->caps().name, r->live, o.count, ro.width, ro.height, o.oit, o.steps);
  fmt::print("  simulate {:9.3f} ms  render {:9.3f} ms (splat {:.3f}, blend {:.3f}, composite {:.3f}, splat resolve "
             "{:.3f})  total {:9.3f} ms (medians)\n",
             r->simulateMs, r->frameMs, r->splatMs, r->blendMs, r->compositeMs, r->splatResolveMs, r->totalMs);
  if (r->splatBinned)
    fmt::print("  splat passes: count {:.3f}, scan {:.3f}, scatter {:.3f}, tiles {:.3f} ms (medians)\n",
               r->splatCountMs, r->splatScanMs, r->splatScatterMs, r->splatTilesMs);
  fmt::print("  billboards {} of {} live particles ({})\n", r->billboards, r->live,
             !ro.splat        ? "splat off"
             : r->splatBinned ? "the rest splatted, binned"
                              : "the rest splatted, atomics");
  fmt::print("  oit fragments {}  msl {:.3f}  oit_dropped {}\n", r->oit.fragments, r->oit.msl, r->oit.dropped());
}

void runBenchParticles(const BenchParticlesOptions& o) {
  auto effect = particles::loadEffectFile(o.input);
  if (!effect) return fail(effect.error());
  if (o.render) {
    if (o.sim != "gpu") return fail("--render needs --sim gpu");
    return runBenchParticlesRender(o, *effect);
  }
  particles::BenchOptions bo;
  bo.count = o.count;
  bo.steps = o.steps;
  particles::BenchResult r;
  std::string device = "cpu";
  if (o.sim == "cpu") {
    auto result = particles::benchCpu(*effect, bo);
    if (!result) return fail(result.error());
    r = *result;
    device = fmt::format("cpu ({} threads)", r.threads);
  } else {
    auto ctx = openDevice(o.device);
    if (!ctx) return fail(ctx.error());
    auto result = particles::benchGpu(**ctx, *effect, bo);
    if (!result) return fail(result.error());
    r = *result;
    device = (*ctx)->caps().name;
  }
  if (o.json) {
    nlohmann::json j = {{"bench", "particles"},
                        {"input", o.input},
                        {"sim", o.sim},
                        {"device", device},
                        {"count", o.count},
                        {"live", r.live},
                        {"steps", o.steps},
                        {"fill_steps", r.fillSteps},
                        {"median_step_ms", r.medianStepMs},
                        {"mean_step_ms", r.meanStepMs},
                        {"min_step_ms", r.minStepMs},
                        {"output_ms", r.outputMs}};
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("bench particles {} on {}: {} live particles ({} asked) in {} systems, {} timed steps after {} to fill\n",
             o.input, device, r.live, o.count, effect->systems.size(), o.steps, r.fillSteps);
  fmt::print("  step {:9.3f} ms median, {:.3f} mean, {:.3f} min ({:.1f} M particles/s)\n", r.medianStepMs, r.meanStepMs,
             r.minStepMs, double(r.live) / std::max(r.medianStepMs, 1e-9) * 1e-3);
  fmt::print("  render records {:9.3f} ms (one output of every live particle)\n", r.outputMs);
}

} // namespace

void addBenchParticlesCommand(CLI::App& bench) {
  auto* b = bench.add_subcommand("particles", "Particle simulation: ms per step of an effect scaled to N particles");
  auto o = std::make_shared<BenchParticlesOptions>();
  b->add_option("input", o->input, "Effect file (.toml), e.g. examples/particles/smoke.toml")->required();
  b->add_option("--count", o->count, "Particles (the effect's systems share them)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 30))
      ->capture_default_str();
  b->add_option("--steps", o->steps, "Timed steps (after the untimed ones that fill the pools)")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  b->add_option("--sim", o->sim, "Simulation: cpu (oneTBB) or gpu (Vulkan compute)")
      ->check(CLI::IsMember({"cpu", "gpu"}))
      ->capture_default_str();
  b->add_option("--device", o->device, "--sim gpu: Vulkan device name substring or index");
  b->add_flag("--json", o->json, "Print results as JSON");
  b->add_flag("--render", o->render,
              "--sim gpu: also draw every live particle each frame (billboards through the transparency lists); "
              "--steps frames timed");
  b->add_option("--size", o->size, "--render: image size WxH")->capture_default_str();
  b->add_option("--oit", o->oit, "--render: linked-list, weighted or sorted")->capture_default_str();
  b->add_option("--camera", o->camera, "--render: eye=x,y,z,target=x,y,z[,fov=60] (default: frame the effect)");
  b->add_flag("--no-splat", o->noSplat, "--render: draw every particle as a billboard (no compute splat)");
  b->add_option("--splat-method", o->splatMethod,
                "--render: the splat's sums binned by screen tiles (shared memory) or by global atomics per pixel")
      ->check(CLI::IsMember({"auto", "binned", "atomic"}))
      ->capture_default_str();
  b->add_flag("--separate-output", o->separateOutput,
              "--render: write the render records by a pass of their own after the step (not by the step itself)");
  b->callback([o] { runBenchParticles(*o); });
}

} // namespace mirage::cli
