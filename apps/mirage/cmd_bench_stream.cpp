// mirage bench stream SCENE [--path orbit:60] [--size WxH] [--codec h264|zstd] [--bitrate MBIT]
//   [--clients N] [--encode-workers W] [--encoder-threads T] [--latency-frames K] [--max-patch-edge L]
//   [--position-bits B] [--visibility M] [--particles FX.toml [--particle-patches merged|each]] [--no-quality]
//   [--json]: Shading Atlas Streaming measured in one process (mirage/stream/bench.h).
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/stream/bench.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct BenchStreamOptions {
  stream::StreamBenchConfig config;
  std::string size = "1920x1080";
  std::string codec = "h264";
  double bitrateMbit = 20.0;
  std::string bitrateScope = "link";
  bool noQuality = false;
  std::string device;
  bool json = false;
};

void runBenchStream(BenchStreamOptions& o) {
  stream::StreamBenchConfig& c = o.config;
  if (auto s = parseSize(o.size, c.width, c.height); !s) return fail(s.error());
  c.codec = o.codec == "zstd"   ? stream::AtlasCodec::ZstdTiles
            : o.codec == "jpeg" ? stream::AtlasCodec::JpegTiles
                                : stream::AtlasCodec::H264;
  if (!(o.bitrateMbit > 0.0 && o.bitrateMbit <= 1000.0)) return fail("--bitrate must be in (0, 1000] Mbit/s");
  c.bitrateKbps = uint32_t(o.bitrateMbit * 1000.0);
  c.linkBudget = o.bitrateScope == "link";
  c.quality = !o.noQuality;
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto report = stream::runStreamBench(**ctx, c);
  if (!report) return fail(report.error());
  const auto& r = *report;
  double gpuVis = 0, gpuShade = 0, gpuConvert = 0, texels = 0, visible = 0, colourOnly = 0, atlasKB = 0, geometryKB = 0,
         levelBias = 0, rawKB = 0;
  double visibilityMs = 0, shadingMs = 0, readbackMs = 0, encodeMs = 0, patchesMs = 0;
  double levelsMs = 0, allocateMs = 0, blocksMs = 0;
  double videoTargetMbit = 0;
  double entries = 0, blockOnly = 0, removed = 0, colours = 0;
  double particles = 0, looks = 0, lookColourOnly = 0, particleTexels = 0, particleKB = 0, particleRawKB = 0;
  for (const auto& f : r.frames) {
    particles += f.particles.visible, looks += f.particles.looks, lookColourOnly += f.particles.colourOnly;
    particleTexels += double(f.particles.texels), particleKB += f.particleBytes / 1024.0;
    particleRawKB += f.particleRawBytes / 1024.0;
    gpuVis += f.gpuVisibilityMs, gpuShade += f.gpuShadingMs, gpuConvert += f.gpuConvertMs;
    levelsMs += f.levelsMs, allocateMs += f.allocateMs, blocksMs += f.blocksMs;
    visibilityMs += f.visibilityMs, shadingMs += f.shadingMs, readbackMs += f.readbackMs, encodeMs += f.encodeMs,
        patchesMs += f.patchesMs, texels += double(f.shadedTexels);
    visible += f.visiblePatches, colourOnly += f.colourOnly, levelBias += f.levelBias, atlasKB += f.atlasBytes / 1024.0,
        geometryKB += f.geometryBytes / 1024.0;
    rawKB += f.geometryRawBytes / 1024.0, entries += f.geometryEntries, blockOnly += f.blockOnlyEntries;
    removed += f.removed, colours += f.colours;
    videoTargetMbit += f.videoTargetKbps / 1000.0;
  }
  double n = double(std::max<size_t>(1, r.frames.size()));
  std::map<std::string, double> passes; // mean GPU time of each pass per client frame
  for (const auto& f : r.frames)
    for (const auto& [name, ms] : f.gpuPasses) passes[name] += ms / n;
  // Client 0's bytes (atlas, geometry, colours, particles) per atlas texel the server shaded for it.
  double bytesPerTexel = texels > 0 ? (atlasKB + geometryKB + particleKB) * 1024.0 / texels : 0.0;
  if (o.json) {
    nlohmann::json j = {{"scene", c.input},
                        {"device", r.device},
                        {"visibility", nameOf(render::kAtlasVisibilityMethodNames, r.visibility)},
                        {"size", o.size},
                        {"codec", o.codec},
                        {"bitrate_mbit", o.bitrateMbit},
                        {"clients", c.clients},
                        {"encode_workers", r.encodeWorkers},
                        {"encoder_threads", c.encoderThreads},
                        {"latency_frames", c.latencyFrames},
                        {"frames", r.frames.size()},
                        {"triangles_source", r.tessellation.trianglesBefore},
                        {"triangles", r.tessellation.trianglesAfter},
                        {"max_patch_edge", r.tessellation.maxPatchEdge},
                        {"patches", r.patches},
                        {"bytes_per_texel", bytesPerTexel},
                        {"server_ms", r.meanServerMs},
                        {"gpu_ms", r.meanGpuMs},
                        {"gpu_visibility_ms", gpuVis / n},
                        {"gpu_shading_ms", gpuShade / n},
                        {"gpu_passes", passes},
                        {"gpu_convert_ms", gpuConvert / n},
                        {"visibility_ms", visibilityMs / n},
                        {"shading_ms", shadingMs / n},
                        {"levels_ms", levelsMs / n},
                        {"allocate_ms", allocateMs / n},
                        {"blocks_ms", blocksMs / n},
                        {"readback_ms", readbackMs / n},
                        {"encode_ms", encodeMs / n},
                        {"patches_ms", patchesMs / n},
                        {"shaded_texels", texels / n},
                        {"visible_patches", visible / n},
                        {"colour_only_patches", colourOnly / n},
                        {"level_bias", levelBias / n},
                        {"atlas_kb", atlasKB / n},
                        {"geometry_kb", geometryKB / n},
                        {"geometry_raw_kb", rawKB / n},
                        {"geometry_entries", entries / n},
                        {"block_only_entries", blockOnly / n},
                        {"removed", removed / n},
                        {"colours", colours / n},
                        {"mbit_s", r.megabitsPerSecond},
                        {"bitrate_scope", o.bitrateScope},
                        {"video_target_mbit", videoTargetMbit / n},
                        {"server_seconds", r.serverSeconds},
                        {"frames_per_second", r.framesPerSecond},
                        {"clients_at_30hz", r.clientsAt30Hz}};
    if (!c.particles.empty())
      j.update({{"particles", c.particles},
                {"particle_patches", nameOf(stream::kParticlePatchesNames, c.particlePatches)},
                {"visible_particles", particles / n},
                {"particle_looks", looks / n},
                {"particle_colour_only_looks", lookColourOnly / n},
                {"particle_texels", particleTexels / n},
                {"particle_kb", particleKB / n},
                {"particle_raw_kb", particleRawKB / n}});
    if (c.quality) j.update({{"ssim", r.meanSsim}, {"ssim_min", r.minSsim}, {"psnr", r.meanPsnr}});
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("stream {} on {}: {} frames at {}, {} client(s), {} at {:.0f} Mbit/s, round trip {} frames, {} "
             "visibility\n",
             c.input, r.device, r.frames.size(), o.size, c.clients, o.codec, o.bitrateMbit, c.latencyFrames,
             nameOf(render::kAtlasVisibilityMethodNames, r.visibility));
  fmt::print("  scene: {} triangles, {} after tessellation to edges <= {:g}, {} patches\n",
             r.tessellation.trianglesBefore, r.tessellation.trianglesAfter, r.tessellation.maxPatchEdge, r.patches);
  fmt::print("  server per client frame: {:.2f} ms wall (visibility {:.2f}, shading {:.2f}, readback {:.2f}, "
             "encode {:.2f}, patches {:.2f}), GPU {:.3f} ms (visibility {:.3f}, shading {:.3f}, YUV {:.3f}); "
             "{:.0f} patches visible ({:.0f} colour-only: no block), {:.2f} M texels shaded, level bias {:.2f} after "
             "fitting the atlas\n",
             r.meanServerMs, visibilityMs / n, shadingMs / n, readbackMs / n, encodeMs / n, patchesMs / n, r.meanGpuMs,
             gpuVis / n, gpuShade / n, gpuConvert / n, visible / n, colourOnly / n, texels / n / 1e6, levelBias / n);
  fmt::print("  client 0: {:.1f} KB atlas + {:.1f} KB geometry + {:.1f} KB particles per frame = {:.1f} Mbit/s at {} "
             "Hz, {:.3f} bytes per texel shaded\n",
             atlasKB / n, geometryKB / n, particleKB / n, r.megabitsPerSecond, c.fps, bytesPerTexel);
  fmt::print("  geometry per frame: {:.1f} KB before zstd; {:.0f} entries with positions, {:.0f} block-only, "
             "{:.0f} removed, {:.0f} colours\n",
             rawKB / n, entries / n, blockOnly / n, removed / n, colours / n);
  if (!c.particles.empty())
    fmt::print("  particles ({}, {} patches) per frame: {:.0f} visible, {:.0f} looks with blocks asked for ({:.0f} "
               "without: one colour), {:.0f} texels shaded, {:.1f} KB ({:.1f} KB before zstd)\n",
               c.particles, nameOf(stream::kParticlePatchesNames, c.particlePatches), particles / n, looks / n,
               lookColourOnly / n, particleTexels / n, particleKB / n, particleRawKB / n);
  if (c.quality)
    fmt::print("  quality against local rendering: SSIM mean {:.4f} min {:.4f}, PSNR {:.2f} dB\n", r.meanSsim,
               r.minSsim, r.meanPsnr);
  fmt::print("  server throughput: {:.1f} client frames/s ({} clients, {} encode workers): {:.2f} clients at 30 Hz\n",
             r.framesPerSecond, c.clients, r.encodeWorkers, r.clientsAt30Hz);
}

} // namespace

void addBenchStreamCommand(CLI::App& bench) {
  auto* b = bench.add_subcommand("stream", "Shading Atlas Streaming: server cost, bytes and client quality per frame");
  auto o = std::make_shared<BenchStreamOptions>();
  stream::StreamBenchConfig& c = o->config;
  b->add_option("input", c.input, "Scene file or gen:KIND[:SIZE]")->capture_default_str();
  b->add_option("--materials", c.materials, "Material file (TOML)");
  b->add_option("--path", c.path, "Camera path: cams.json or orbit:N")->capture_default_str();
  b->add_option("--size", o->size, "Client viewport WxH")->capture_default_str();
  b->add_option("--codec", o->codec, "Atlas codec: h264, zstd or jpeg")
      ->check(CLI::IsMember({"h264", "zstd", "jpeg"}))
      ->capture_default_str();
  b->add_option("--bitrate", o->bitrateMbit, "H.264 target, Mbit/s")->capture_default_str();
  b->add_option("--bitrate-scope", o->bitrateScope, kBitrateScopeHelp)
      ->check(CLI::IsMember({"link", "video"}))
      ->capture_default_str();
  b->add_option("--fps", c.fps, "Frames per second the path is played at")->capture_default_str();
  b->add_option("--clients", c.clients, "Clients served at once (throughput: with --no-quality)")
      ->capture_default_str();
  bindEncoding(*b, c.encodeWorkers, c.encoderThreads);
  b->add_option("--latency-frames", c.latencyFrames, "Round trip in frames")->capture_default_str();
  b->add_option("--atlas-size", c.atlasSize, "Atlas side in texels")->capture_default_str();
  b->add_option("--level-bias", c.levelBias, "Atlas texels per pixel: block side x 2^bias")->capture_default_str();
  b->add_option("--atlas-fill", c.atlasFill, kAtlasFillHelp)->check(CLI::Range(0.0f, 1.0f))->capture_default_str();
  bindTessellation(*b, c.tessellation);
  bindVisibility(*b, c.visibility);
  b->add_option("--position-bits", c.positionBits, "Bits per axis of the patch position grid (8..24)")
      ->capture_default_str();
  bindParticles(*b, c.particles, c.particlePatches);
  b->add_flag("--no-quality", o->noQuality, "Skip the client's images and their comparison with local rendering");
  b->add_option("--device", o->device, "Vulkan device name substring or index");
  b->add_flag("--json", o->json, "Print results as JSON");
  b->callback([o] { runBenchStream(*o); });
}

} // namespace mirage::cli
