// mirage particles FX.toml [--scene SCENE] [--frames N] [--dt 1/60] [--camera ...|--path P]
// [--every K] [--sim cpu|gpu] [--size WxH] [--oit MODE] [--no-splat] -o out.png: an effect rendered after N
// steps (mirage/particles/render.h).
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/particles/render.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct ParticlesOptions {
  particles::ParticleRenderRequest request;
  std::string dt = "1/60";
  std::string sim = "cpu";
  std::string oit = "linked-list";
  std::string size = "640x360";
  std::string device;
  bool json = false;
  bool noSplat = false;
};

void runParticles(ParticlesOptions& o) {
  particles::ParticleRenderRequest& r = o.request;
  auto dt = particles::parseTimeStep(o.dt);
  if (!dt) return fail(dt.error());
  r.dt = *dt;
  auto sim = parseNamed(o.sim, "--sim", particles::kSimKindNames);
  if (!sim) return fail(sim.error());
  r.sim = *sim;
  auto oit = render::parseOitMode(o.oit);
  if (!oit) return fail(oit.error());
  r.oit = *oit;
  if (auto s = parseSize(o.size, r.width, r.height); !s) return fail(s.error());
  r.splat = !o.noSplat;
  if (auto s = checkOutputPath(r.output, {".png"}); !s) return fail(s.error());
  if (auto s = particles::validate(r); !s) return fail(s.error());
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto report = particles::renderParticles(**ctx, r);
  if (!report) return fail(report.error());
  if (o.json) {
    nlohmann::json j = {{"effect", r.effect},
                        {"scene", r.scene},
                        {"sim", o.sim},
                        {"frames", r.frames},
                        {"dt", r.dt},
                        {"live", report->live},
                        {"images", report->written},
                        {"oit", o.oit},
                        {"msl", report->oit.msl},
                        {"oit_dropped", report->oit.dropped()}};
    for (const auto& t : report->passTimes) j["gpu_ms"][t.name] = t.milliseconds;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("rendered {} ({} live particles after {} steps of {:.4f} s, {} sim) at {}x{} on {} -> {}{}\n", r.effect,
             report->live, r.frames, r.dt, o.sim, r.width, r.height, (*ctx)->caps().name, report->written.front(),
             report->written.size() > 1
                 ? fmt::format(" .. {} ({} images)", report->written.back(), report->written.size())
                 : "");
}

} // namespace

void addParticlesCommand(CLI::App& app) {
  auto* c = app.add_subcommand("particles", "Render a particle effect (docs/particles.md) over a scene or a ground");
  auto o = std::make_shared<ParticlesOptions>();
  particles::ParticleRenderRequest& r = o->request;
  c->add_option("input", r.effect, "Effect file (.toml), e.g. examples/particles/fire.toml")->required();
  c->add_option("-o,--output", r.output, "Output PNG (numbered out_0000.png.. with --path or --every)")->required();
  c->add_option("--scene", r.scene, "Scene file or gen:KIND (default: a ground under the effect)");
  c->add_option("--frames", r.frames, "Simulation steps before the image")->capture_default_str();
  c->add_option("--dt", o->dt, "Seconds per step, e.g. 0.02 or 1/60")->capture_default_str();
  c->add_option("--camera", r.camera, "eye=x,y,z,target=x,y,z,fov=60 (default: frame the effect, or the scene)");
  c->add_option("--path", r.path, "Camera path (cams.json or orbit:N): image i after frames + i steps");
  c->add_option("--every", r.every, "An image every K steps up to --frames (numbered)");
  c->add_option("--sim", o->sim, "Simulation: cpu or gpu")->capture_default_str();
  c->add_option("--oit", o->oit, "Transparency: linked-list, weighted or sorted")->capture_default_str();
  c->add_option("--size", o->size, "Image size WxH")->capture_default_str();
  c->add_option("--device", o->device, "Vulkan device name substring or index");
  c->add_flag("--no-splat", o->noSplat, "Draw every particle as a billboard (no compute splat of small ones)");
  c->add_flag("--json", o->json, "Print the result as JSON");
  c->callback([o] { runParticles(*o); });
}

} // namespace mirage::cli
