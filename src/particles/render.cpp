// An effect's simulation feeding the forward renderer's particle billboards, and `mirage
// particles` (mirage/particles/render.h, docs/particles.md "Rendering").
#include "mirage/particles/render.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "mirage/io/image_io.h"
#include "mirage/particles/gpu_simulation.h"
#include "mirage/particles/sheet.h"
#include "mirage/particles/simulation.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/runtime/scene_argument.h"

namespace mirage::particles {

namespace sio = mirage::shaderio;

Result<std::vector<render::ParticleSheet>> effectSheets(const EffectFile& effect) {
  std::vector<render::ParticleSheet> out;
  for (const SystemDef& s : effect.systems) {
    auto image = systemSheet(s);
    if (!image) return makeError(effect.name, image.error().message);
    out.push_back({std::move(*image), s.sheet.tilesX, s.sheet.tilesY, s.sheet.alphaFromGreyscale});
  }
  return out;
}

struct EffectPlayer::Impl {
  gpu::Context& ctx;
  SimKind kind;
  std::unique_ptr<render::ParticleDraw> draw;
  Simulation cpu;
  std::vector<sio::RenderParticle> cpuRecords;
  std::unique_ptr<GpuSimulation> gpu;
  std::vector<uint32_t> capacities; // per system (GPU batches)
  explicit Impl(gpu::Context& c) : ctx(c) {}

  // The draw's batches from the simulation's current state.
  void publish() {
    if (kind == SimKind::Cpu) {
      cpuRecords.resize(liveParticles(cpu));
      writeRenderParticles(cpu, cpuRecords);
      std::vector<render::ParticleDraw::CpuBatch> batches;
      size_t at = 0;
      for (uint32_t i = 0; i < cpu.pools.size(); ++i) {
        uint32_t n = cpu.pools[i].live;
        batches.push_back({std::span<const sio::RenderParticle>(cpuRecords).subspan(at, n), i});
        at += n;
      }
      draw->setCpuBatches(batches);
      return;
    }
    ctx.submitAndWait([&](VkCommandBuffer cmd) { gpu->cmdWriteRender(cmd); });
    std::vector<render::ParticleBatch> batches;
    for (uint32_t i = 0; i < gpu->systemCount(); ++i)
      batches.push_back({gpu->renderBuffer(i).address(), gpu->counterBuffer(i).handle(),
                         offsetof(sio::ParticleCounters, live), capacities[i], i});
    draw->setBatches(std::move(batches));
  }
};

EffectPlayer::EffectPlayer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
EffectPlayer::~EffectPlayer() = default;

Result<std::unique_ptr<EffectPlayer>> EffectPlayer::create(gpu::Context& context, const EffectFile& effect, SimKind sim,
                                                           float dt) {
  auto sheets = effectSheets(effect);
  if (!sheets) return sheets.error();
  auto d = std::make_unique<Impl>(context);
  d->kind = sim;
  auto draw = render::ParticleDraw::create(context, *sheets);
  if (!draw) return makeError(effect.name, draw.error().message);
  d->draw = std::move(*draw);
  if (sim == SimKind::Cpu) {
    d->cpu = makeSimulation(effect, dt);
  } else {
    d->gpu = std::make_unique<GpuSimulation>(context, effect, dt);
    for (const SystemDef& s : effect.systems) d->capacities.push_back(s.maxParticles);
  }
  d->publish();
  return std::unique_ptr<EffectPlayer>(new EffectPlayer(std::move(d)));
}

void EffectPlayer::step(uint32_t steps) {
  Impl& d = *impl_;
  if (steps == 0) return;
  if (d.kind == SimKind::Cpu)
    for (uint32_t i = 0; i < steps; ++i) particles::step(d.cpu);
  else
    d.gpu->step(steps);
  d.publish();
}

render::ParticleDraw* EffectPlayer::draw() { return impl_->draw.get(); }

uint64_t EffectPlayer::live() {
  return impl_->kind == SimKind::Cpu ? liveParticles(impl_->cpu) : impl_->gpu->liveParticles();
}

std::vector<sio::RenderParticle> EffectPlayer::records() {
  return impl_->kind == SimKind::Cpu ? impl_->cpuRecords : impl_->gpu->readRender();
}

Bounds EffectPlayer::bounds() {
  Bounds b;
  for (const sio::RenderParticle& r : records()) {
    b.add(r.position - glm::vec3(0.5f * r.size));
    b.add(r.position + glm::vec3(0.5f * r.size));
  }
  return b;
}

Result<std::unique_ptr<EffectPlayer>> playEffect(gpu::Context& context, const std::string& path, uint32_t steps,
                                                 SimKind sim, float dt) {
  auto effect = loadEffectFile(path);
  if (!effect) return effect.error();
  auto player = EffectPlayer::create(context, *effect, sim, dt);
  if (!player) return player.error();
  (*player)->step(steps);
  return player;
}

render::Camera clipAround(const render::Camera& camera, const Bounds& scene, const Bounds& effect) {
  Bounds all = scene;
  if (!effect.empty()) {
    all.add(effect.min - effect.extent());
    all.add(effect.max + effect.extent());
  }
  return render::withClipPlanes(camera, all);
}

Scene groundScene(const Bounds& effectBounds) {
  Bounds b = effectBounds;
  if (b.empty()) b.add(glm::vec3(-1.0f)), b.add(glm::vec3(1.0f));
  glm::vec3 c = b.center();
  float h = 1.5f * std::max({b.extent().x, b.extent().z, 1.0f});
  float y = b.min.y;
  Scene s;
  s.source = "generated:ground";
  Mesh m;
  m.name = "ground";
  m.positions = {{c.x - h, y, c.z - h}, {c.x + h, y, c.z - h}, {c.x + h, y, c.z + h}, {c.x - h, y, c.z + h}};
  m.normals.assign(4, glm::vec3(0.0f, 1.0f, 0.0f));
  m.indices = {0, 2, 1, 0, 3, 2};
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
  Material mat;
  mat.name = "ground";
  mat.baseColorFactor = {0.32f, 0.31f, 0.29f, 1.0f};
  mat.metallicFactor = 0.0f;
  mat.roughnessFactor = 0.9f;
  mat.doubleSided = true; // seen from below too
  s.meshes.push_back(std::move(m));
  s.materials.push_back(mat);
  s.instances.push_back({0, glm::mat4(1.0f)});
  return s;
}

Result<float> parseTimeStep(const std::string& text) {
  size_t slash = text.find('/');
  try {
    size_t used = 0;
    if (slash == std::string::npos) {
      float v = std::stof(text, &used);
      if (used == text.size()) return v;
    } else {
      std::string num = text.substr(0, slash), den = text.substr(slash + 1);
      size_t usedDen = 0;
      float a = std::stof(num, &used), b = std::stof(den, &usedDen);
      if (used == num.size() && usedDen == den.size() && b != 0.0f) return a / b;
    }
  } catch (const std::exception&) {
  }
  return Error{fmt::format("--dt '{}': expected seconds, e.g. 0.02 or 1/60", text)};
}

Status validate(const ParticleRenderRequest& r) {
  if (!(r.dt > 0.0f) || !(r.dt <= 1.0f)) return Error{fmt::format("--dt {}: must be in (0, 1] seconds", r.dt)};
  if (r.frames > 1000000) return Error{fmt::format("--frames {}: at most 1000000", r.frames)};
  if (r.every > 0 && !r.path.empty()) return Error{"--every and --path exclude each other"};
  if (r.every > 0 && r.frames / r.every > 10000) return Error{"--every: more than 10000 images"};
  if (r.width == 0 || r.height == 0 || r.width > render::kMaxRenderDimension || r.height > render::kMaxRenderDimension)
    return Error{
        fmt::format("--size {}x{}: each side must be in 1..{}", r.width, r.height, render::kMaxRenderDimension)};
  if (std::filesystem::path(r.output).extension() != ".png")
    return makeError(r.output, "the output must be a .png file");
  return Ok{};
}

Result<ParticleRenderReport> renderParticles(gpu::Context& ctx, const ParticleRenderRequest& r) {
  if (Status s = validate(r); !s) return s.error();
  auto effect = loadEffectFile(r.effect);
  if (!effect) return effect.error();
  return renderParticles(ctx, *effect, r);
}

Result<ParticleRenderReport> renderParticles(gpu::Context& ctx, const EffectFile& effectFile,
                                             const ParticleRenderRequest& r) {
  if (Status s = validate(r); !s) return s.error();
  std::optional<render::Camera> fixedCamera;
  if (!r.camera.empty()) {
    auto c = render::parseCamera(r.camera);
    if (!c) return c.error();
    fixedCamera = *c;
  }
  const EffectFile* effect = &effectFile;
  std::optional<Scene> scene;
  if (!r.scene.empty()) {
    auto loaded = runtime::loadSceneArgument(r.scene);
    if (!loaded) return loaded.error();
    scene = std::move(*loaded);
  }
  auto player = EffectPlayer::create(ctx, *effect, r.sim, r.dt);
  if (!player) return player.error();
  EffectPlayer& fx = **player;
  if (!r.splat) (void)fx.draw()->setSettings({0.0f}); // billboards only (a valid setting)
  uint32_t first = r.every > 0 ? std::min(r.every, std::max(r.frames, 1u)) : r.frames;
  fx.step(first);
  Bounds fxBounds = fx.bounds();
  if (fxBounds.empty()) // nothing alive yet: the emitters
    for (const SystemDef& s : effect->systems) fxBounds.add(s.position - 1.0f), fxBounds.add(s.position + 1.0f);
  if (!scene) scene = groundScene(fxBounds);
  auto renderer = render::ForwardRenderer::create(ctx, *scene);
  if (!renderer) return renderer.error();
  float aspect = float(r.width) / float(r.height);
  std::vector<render::Camera> cameras;
  if (!r.path.empty()) {
    auto path = render::cameraPathArgument(r.path, r.scene.empty() ? fxBounds : (*renderer)->worldBounds(), aspect);
    if (!path) return path.error();
    cameras = std::move(*path);
  } else {
    cameras.push_back(fixedCamera
                          ? *fixedCamera
                          : render::autoCamera(r.scene.empty() ? fxBounds : (*renderer)->worldBounds(), aspect));
  }
  uint32_t images = !r.path.empty() ? uint32_t(cameras.size()) : (r.every > 0 ? std::max(r.frames / r.every, 1u) : 1);
  bool numbered = images > 1 || !r.path.empty() || r.every > 0;
  ParticleRenderReport report;
  auto cleanup = [&] {
    std::error_code ec;
    for (const std::string& p : report.written) std::filesystem::remove(p, ec);
  };
  for (uint32_t i = 0; i < images; ++i) {
    if (i > 0) fx.step(r.path.empty() ? r.every : 1);
    render::ForwardRenderSettings fs;
    fs.base.width = r.width;
    fs.base.height = r.height;
    fs.base.camera = clipAround(cameras[std::min<size_t>(i, cameras.size() - 1)], (*renderer)->worldBounds(), fxBounds);
    fs.oit = r.oit;
    fs.particles = fx.draw();
    auto out = (*renderer)->render(fs);
    if (!out) return cleanup(), out.error();
    std::string name = numbered ? render::pathFrameName(r.output, i) : r.output;
    if (Status s = io::writePng(name, out->srgb); !s) return cleanup(), s.error();
    report.written.push_back(name);
    report.oit = out->stats.oit;
    report.passTimes = out->stats.passTimes;
  }
  report.live = fx.live();
  return report;
}

} // namespace mirage::particles
