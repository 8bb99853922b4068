// mirage surfels INPUT -o out.ply|out.mrg: progressive blue-noise surfels of a scene (issue 5).
#include <chrono>

#include <fmt/format.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/gpu_sampler.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct SurfelsOptions {
  std::string input;
  std::string output;
  std::string device;
  uint32_t count = 100000;
  uint32_t resolution = 1024;
  uint32_t views = 16;
  float threshold = 0.75f;
  bool reference = false;
};

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void runSurfels(const SurfelsOptions& o) {
  // Everything cheap first, so bad input fails before the import and the GPU start.
  if (auto s = checkOutputPath(o.output, {".ply", ".mrg"}); !s) return fail(s.error());
  if (o.count == 0) return fail("--count must be at least 1");
  if (o.views == 0 || o.views > 256) return fail("--views must be in 1..256");
  if (o.resolution == 0) return fail("--resolution must be at least 1");
  if (!(o.threshold > 0.0f && o.threshold <= 1.0f)) return fail("--threshold must be in (0, 1]");

  auto t0 = std::chrono::steady_clock::now();
  auto scene = loadSceneArgument(o.input);
  if (!scene) return fail(scene.error());
  double importSeconds = secondsSince(t0);
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());

  surfels::CaptureConfig cc;
  cc.resolution = o.resolution;
  cc.views = o.views;
  t0 = std::chrono::steady_clock::now();
  auto gb = surfels::captureGBuffer(**ctx, *scene, cc);
  if (!gb) return fail(gb.error());
  double captureSeconds = secondsSince(t0);
  const surfels::GBufferTexels& texels = gb->texels;

  surfels::GpuSamplerConfig sc;
  sc.count = o.count;
  sc.threshold = o.threshold;
  auto sampled = surfels::sampleOnGpu(**ctx, *gb, sc);
  if (!sampled) return fail(sampled.error());
  const surfels::SampleOrder& order = sampled->order;

  surfels::SampleOrder reference;
  double referenceSeconds = 0.0;
  if (o.reference) {
    t0 = std::chrono::steady_clock::now();
    reference = surfels::farthestPointReference(texels, o.count);
    referenceSeconds = secondsSince(t0);
  }

  surfels::SurfelCloud cloud = surfels::buildSurfelCloud(texels, order);
  Status written =
      o.output.ends_with(".mrg") ? surfels::writeSurfelMrg(o.output, cloud) : surfels::writeSurfelPly(o.output, cloud);
  if (!written) return fail(written.error());

  fmt::print("surfels {} -> {}: {} surfels from {} texels ({} views x {}^2, {} capture pass(es)) on {}\n", o.input,
             o.output, cloud.size(), texels.size(), o.views, o.resolution, gb->passes, (*ctx)->caps().name);
  fmt::print("sampled area A = {:.6g} (texel size {:.4g}); N_ref {} mean spacing {:.4g} median {:.4g}\n",
             texels.totalArea, texels.texelSize, cloud.referenceCount, cloud.referenceMeanSpacing,
             cloud.referenceMedianSpacing);
  fmt::print("import {:.3f} s, capture {:.3f} s (with readback and areas), sampler {:.3f} s in {} rounds",
             importSeconds, captureSeconds, sampled->seconds, sampled->rounds);
  if (o.reference) fmt::print(", CPU reference {:.3f} s", referenceSeconds);
  fmt::print("\n");
  for (const auto& t : gb->times) fmt::print("gpu {:<10} {:10.3f} ms\n", t.name, t.milliseconds);
  for (const auto& t : sampled->times) fmt::print("gpu {:<10} {:10.3f} ms (sum over rounds)\n", t.name, t.milliseconds);
  fmt::print("{:>8} {:>10} {:>7} {:>9}{}\n", "prefix", "radius", "rho", "coverage",
             o.reference ? "   ref rho ref coverage" : "");
  std::vector<uint32_t> prefixes;
  for (uint32_t n : {1000u, 10000u, 100000u, 1000000u})
    if (n < cloud.size()) prefixes.push_back(n);
  prefixes.push_back(uint32_t(cloud.size()));
  for (uint32_t n : prefixes) {
    surfels::PrefixQuality q = surfels::measurePrefix(texels, order, n);
    fmt::print("{:>8} {:>10.4g} {:>7.3f} {:>9.4f}", n, q.radius, q.rho, q.coverage);
    if (o.reference) {
      surfels::PrefixQuality r = surfels::measurePrefix(texels, reference, n);
      fmt::print(" {:>9.3f} {:>12.4f}", r.rho, r.coverage);
    }
    fmt::print("\n");
  }
}

} // namespace

void addSurfelsCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("surfels", "Sample progressive blue-noise surfels of a scene (PLY or .mrg)");
  auto o = std::make_shared<SurfelsOptions>();
  cmd->add_option("input", o->input, "Scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]")->required();
  cmd->add_option("-o,--output", o->output, "Output .ply (x y z nx ny nz red green blue alpha radius) or .mrg")
      ->required();
  cmd->add_option("--count", o->count, "Surfels to sample")->capture_default_str();
  cmd->add_option("--resolution", o->resolution, "G-buffer resolution per view")->capture_default_str();
  cmd->add_option("--views", o->views, "Orthographic capture directions (Fibonacci sphere)")->capture_default_str();
  cmd->add_option("--threshold", o->threshold, "Candidate threshold relative to the round's largest radius")
      ->capture_default_str();
  cmd->add_flag("--reference", o->reference, "Also run the exact CPU farthest-point reference and compare");
  cmd->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->callback([o] { runSurfels(*o); });
}

} // namespace mirage::cli
