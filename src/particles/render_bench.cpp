// `mirage bench particles --render` (mirage/particles/render.h): simulation and billboard
// rendering of a scaled effect timed together on the GPU.
#include <algorithm>
#include <optional>

#include "mirage/particles/bench.h"
#include "mirage/particles/gpu_simulation.h"
#include "mirage/particles/render.h"
#include "mirage/particles/simulation.h"
#include "mirage/render/forward_renderer.h"

namespace mirage::particles {

namespace sio = mirage::shaderio;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The unscaled effect's extent after the fill time (CPU, its own small counts): what the camera frames.
Bounds effectExtent(const EffectFile& effect, float dt, uint64_t steps) {
  Simulation sim = makeSimulation(effect, dt);
  for (uint64_t i = 0; i < std::min<uint64_t>(steps, 600); ++i) step(sim);
  std::vector<sio::RenderParticle> records(liveParticles(sim));
  writeRenderParticles(sim, records);
  Bounds b;
  for (const sio::RenderParticle& r : records)
    b.add(r.position - glm::vec3(r.size)), b.add(r.position + glm::vec3(r.size));
  if (b.empty())
    for (const SystemDef& s : effect.systems) b.add(s.position - 1.0f), b.add(s.position + 1.0f);
  return b;
}

} // namespace

Result<RenderBenchResult> benchRender(gpu::Context& context, const EffectFile& effect, const RenderBenchOptions& o) {
  std::optional<render::Camera> fixedCamera;
  if (!o.camera.empty()) { // before any GPU work
    auto parsed = render::parseCamera(o.camera);
    if (!parsed) return parsed.error();
    fixedCamera = *parsed;
  }
  VkPhysicalDeviceMemoryProperties memory{};
  vkGetPhysicalDeviceMemoryProperties(context.physicalDevice(), &memory);
  uint64_t heap = 0;
  for (uint32_t i = 0; i < memory.memoryHeapCount; ++i)
    if (memory.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      heap = std::max(heap, memory.memoryHeaps[i].size);
  if (Status s =
          checkParticleMemory(o.count, kGpuBytesPerParticle + render::kSplatBytesPerRecord, heap / 2, "device memory");
      !s)
    return s.error();
  EffectFile scaled = scaleEffect(effect, o.count);
  auto sheets = effectSheets(scaled);
  if (!sheets) return sheets.error();
  auto draw = render::ParticleDraw::create(context, *sheets);
  if (!draw) return draw.error();
  RenderBenchResult r;
  r.fillSteps = fillSteps(scaled, o.dt);
  Bounds extent = effectExtent(effect, o.dt, r.fillSteps);
  auto renderer = render::ForwardRenderer::create(context, groundScene(extent));
  if (!renderer) return renderer.error();
  GpuSimulation sim(context, scaled, o.dt);
  sim.step(uint32_t(r.fillSteps));
  std::vector<render::ParticleBatch> batches;
  for (uint32_t i = 0; i < sim.systemCount(); ++i)
    batches.push_back({sim.renderBuffer(i).address(), sim.counterBuffer(i).handle(),
                       offsetof(sio::ParticleCounters, live), scaled.systems[i].maxParticles, i});
  (*draw)->setBatches(std::move(batches));

  render::ParticleDrawSettings drawSettings;
  drawSettings.splatMethod = o.splatMethod;
  if (!o.splat) drawSettings.splatBelowPixels = 0.0f; // billboards only
  if (Status s = (*draw)->setSettings(drawSettings); !s) return s.error();
  render::Camera camera = fixedCamera ? *fixedCamera : render::autoCamera(extent, float(o.width) / float(o.height));
  render::ForwardRenderSettings fs;
  fs.base.width = o.width;
  fs.base.height = o.height;
  fs.base.readImage = false;
  fs.base.camera = clipAround(camera, (*renderer)->worldBounds(), extent);
  fs.oit = o.oit;
  fs.oitNodesPerPixel = o.oitNodesPerPixel;
  fs.particles = draw->get();
  gpu::GpuTimer timer(context, 2); // "total" around "simulate"
  std::vector<double> simulate, frame, blend, composite, splat, splatResolve, total;
  std::vector<double> splatCount, splatScan, splatScatter, splatTiles;
  std::vector<std::pair<std::string, std::vector<double>>> passes; // every pass, in first-run order
  for (uint32_t i = 0; i < o.frames + 1; ++i) {                    // the first warms the pipelines up, untimed
    Status recorded = Ok{};
    context.submitAndWait([&](VkCommandBuffer cmd) {
      timer.cmdReset(cmd);
      // The whole GPU time from the step's start to the frame's end, gaps between passes included.
      uint32_t span = timer.cmdBegin(cmd, "total");
      uint32_t slot = timer.cmdBegin(cmd, "simulate");
      if (o.fusedOutput) {
        sim.cmdStep(cmd, /*writeRender=*/true);
      } else {
        sim.cmdStep(cmd);
        sim.cmdWriteRender(cmd);
      }
      timer.cmdEnd(cmd, slot);
      recorded = (*renderer)->record(cmd, fs, 0); // its first barrier orders the records before the draw
      timer.cmdEnd(cmd, span);
    });
    if (!recorded) return recorded.error();
    auto out = (*renderer)->collect(0);
    if (!out) return out.error();
    if (i == 0) continue;
    std::vector<gpu::PassTime> stepTimes = timer.read();
    double s = gpu::passMilliseconds(stepTimes, "simulate"), f = 0;
    for (const gpu::PassTime& t : out->stats.passTimes) {
      auto pass = std::find_if(passes.begin(), passes.end(), [&](const auto& p) { return p.first == t.name; });
      if (pass == passes.end()) pass = passes.insert(passes.end(), {t.name, {}});
      pass->second.push_back(t.milliseconds);
      if (t.name == "frame") f = t.milliseconds;
      if (t.name == "blend") blend.push_back(t.milliseconds);
      if (t.name == "composite") composite.push_back(t.milliseconds);
      if (t.name == "splat") splat.push_back(t.milliseconds);
      if (t.name == "splat-resolve") splatResolve.push_back(t.milliseconds);
      if (t.name == "splat-count") splatCount.push_back(t.milliseconds);
      if (t.name == "splat-scan") splatScan.push_back(t.milliseconds);
      if (t.name == "splat-scatter") splatScatter.push_back(t.milliseconds);
      if (t.name == "splat-tiles") splatTiles.push_back(t.milliseconds);
    }
    simulate.push_back(s), frame.push_back(f), total.push_back(gpu::passMilliseconds(stepTimes, "total"));
    r.oit = out->stats.oit;
  }
  r.live = sim.liveParticles();
  r.simulateMs = median(simulate);
  r.frameMs = median(frame);
  r.blendMs = median(blend);
  r.compositeMs = median(composite);
  r.splatMs = median(splat);
  r.splatResolveMs = median(splatResolve);
  r.splatCountMs = median(splatCount);
  r.splatScanMs = median(splatScan);
  r.splatScatterMs = median(splatScatter);
  r.splatTilesMs = median(splatTiles);
  r.totalMs = median(total);
  for (auto& [name, ms] : passes) r.passMs.push_back({name, median(ms)});
  r.billboards =
      (*draw)->splats(o.oit) ? (*draw)->readBillboardCount() : uint32_t(std::min<uint64_t>(r.live, UINT32_MAX));
  r.splatBinned = (*draw)->splats(o.oit) && (*draw)->splatsBinned();
  return r;
}

} // namespace mirage::particles
