#pragma once
// Drawing an effect (docs/particles.md, "Rendering"): its simulation (CPU pool or GPU compute)
// feeding the forward renderer's particle billboards (render/particle_draw.h), one batch per
// system with the system's generated texture sheet; and `mirage particles`: an effect over a scene
// or a generated ground, rendered after N steps to PNG files.
#include <memory>
#include <string>
#include <vector>

#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/particles/effect.h"
#include "mirage/render/camera.h"
#include "mirage/render/oit.h"
#include "mirage/render/particle_draw.h"

namespace mirage::particles {

enum class SimKind { Cpu, Gpu };
inline constexpr EnumName<SimKind> kSimKindNames[] = {{SimKind::Cpu, "cpu"}, {SimKind::Gpu, "gpu"}};

// Each system's sheet (systemSheet, particles/sheet.h) with its alpha rule.
Result<std::vector<render::ParticleSheet>> effectSheets(const EffectFile& effect);

// An effect simulated and drawn: step() advances it, draw() is what ForwardRenderSettings::particles
// (or runtime::View::particles) takes, up to date after each step().
class EffectPlayer {
public:
  static Result<std::unique_ptr<EffectPlayer>> create(gpu::Context& context, const EffectFile& effect, SimKind sim,
                                                      float dt);
  ~EffectPlayer();
  void step(uint32_t steps);
  render::ParticleDraw* draw();
  uint64_t live();
  // The live particles' extent (centres grown by half their size); empty without live particles.
  // GPU: reads the records back (blocking).
  Bounds bounds();
  // The render records, system after system (GPU: read back).
  std::vector<shaderio::RenderParticle> records();

  struct Impl;

private:
  explicit EffectPlayer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// `mirage render SCENE --particles FX.toml`: the effect file loaded and stepped `steps` times.
Result<std::unique_ptr<EffectPlayer>> playEffect(gpu::Context& context, const std::string& path, uint32_t steps,
                                                 SimKind sim, float dt);
// The camera's clip planes around the scene and the effect's particles (theirs derive from the
// scene alone), with room for the effect to move on.
render::Camera clipAround(const render::Camera& camera, const Bounds& scene, const Bounds& effect);

// A flat opaque ground under `bounds` (its lowest point), three times its horizontal extent: the
// scene of an effect rendered without one.
Scene groundScene(const Bounds& bounds);

// `mirage particles` (CLI: apps/mirage/cmd_particles.cpp binds these).
struct ParticleRenderRequest {
  std::string effect; // .toml
  std::string scene;  // scene argument (file or gen:); empty: groundScene
  std::string output = "particles.png";
  uint32_t frames = 60; // steps before the (first) image
  float dt = 1.0f / 60.0f;
  std::string camera; // render::parseCamera; empty: frame the effect (or the scene)
  std::string path;   // camera path (cams.json or orbit:N): image i after frames + i steps
  uint32_t every = 0; // > 0 without a path: an image every `every` steps up to `frames`
  SimKind sim = SimKind::Cpu;
  uint32_t width = 640, height = 360;
  render::OitMode oit = render::OitMode::LinkedList;
  bool splat = true; // small particles splatted (render::ParticleDrawSettings); false: billboards only
};
// A time step: seconds as a number ("0.0166") or a fraction ("1/60"). Error: anything else.
Result<float> parseTimeStep(const std::string& text);
// Checks everything cheap (dt, counts, output extension) before the GPU. Errors name the option.
Status validate(const ParticleRenderRequest& request);

struct ParticleRenderReport {
  std::vector<std::string> written; // image paths
  uint64_t live = 0;                // particles in the last image
  render::OitStats oit;             // of the last image
  std::vector<gpu::PassTime> passTimes;
};
// Renders and writes the images (numbered stem_0000.png.. with a path or `every`). On an error no
// image of this call is left behind.
Result<ParticleRenderReport> renderParticles(gpu::Context& context, const ParticleRenderRequest& request);
// The same with the effect already parsed (request.effect unused).
Result<ParticleRenderReport> renderParticles(gpu::Context& context, const EffectFile& effect,
                                             const ParticleRenderRequest& request);

// `mirage bench particles --sim gpu --render`: the effect scaled to `count` particles and filled
// (as benchGpu), then per timed frame one submission with the simulation step and record output
// ("simulate") and the forward frame drawing every live particle over a ground ("frame": opaque,
// splat = the small particles' compute splat (binned: its count, scan, scatter and tile passes
// too), blend = list build, composite = resolve, splat-resolve), GPU times from timestamp queries, medians over the
// frames. The camera frames the unscaled effect unless given.
struct RenderBenchOptions {
  uint64_t count = 1000000;
  uint32_t frames = 50;
  float dt = 1.0f / 60.0f;
  uint32_t width = 1920, height = 1080;
  render::OitMode oit = render::OitMode::LinkedList;
  uint32_t oitNodesPerPixel = 8;
  bool splat = true;                                           // false: every particle a billboard
  render::SplatMethod splatMethod = render::SplatMethod::Auto; // binned by screen tiles, or global atomics
  bool fusedOutput = true; // the step writes the render records (false: a separate output pass after it)
  std::string camera;      // render::parseCamera; empty: frame the unscaled effect
};
struct RenderBenchResult {
  uint64_t live = 0, fillSteps = 0;
  // Medians; total: one span from the step's start to the frame's end (more than simulate + frame
  // by what runs between them, the renderer's clears).
  double simulateMs = 0, frameMs = 0, blendMs = 0, compositeMs = 0, totalMs = 0;
  double splatMs = 0, splatResolveMs = 0; // medians
  // Binned: the splat's passes apart (medians; splat-count, splat-scan, splat-scatter, splat-tiles).
  double splatCountMs = 0, splatScanMs = 0, splatScatterMs = 0, splatTilesMs = 0;
  uint32_t billboards = 0;  // particles the splat left to billboards in the last frame (all without it)
  bool splatBinned = false; // the splat ran binned by screen tiles
  render::OitStats oit;     // of the last frame
  // Every pass of the frame the renderer timed (its "frame" and the splat's included), medians in
  // the order they first ran: where the rest of the frame goes.
  std::vector<std::pair<std::string, double>> passMs;
};
Result<RenderBenchResult> benchRender(gpu::Context& context, const EffectFile& effect,
                                      const RenderBenchOptions& options);

} // namespace mirage::particles
