// mirage serve SCENE [--port 7000] [--token-file F] [--tls-cert C --tls-key K] [--max-clients N]
//   [--codec h264|zstd] [--bitrate MBIT] [--atlas-size N] [--max-patch-edge L] [--position-bits B]
//   [--visibility auto|compute|hardware] [--particles FX.toml [--particle-patches merged|each]] [--web DIR]:
//   Shading Atlas Streaming.
// mirage client ws://HOST:PORT [--token T] [--path cams.json] [--record OUT.png] [--size WxH]
//   [--stereo [--ipd M]] [--latency-ms MS [--jitter-ms J] [--loss P] [--seed S] [--fps F] [--server-ms S]]:
//   the native thin client (docs/stream.md): a window with a fly camera, or with --path / --record a
//   camera path without a window; with --latency-ms open loop under a simulated network.
#include <atomic>
#include <csignal>
#include <memory>

#include <fmt/format.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/io/image_io.h"
#include "mirage/stream/client.h"
#include "mirage/stream/server.h"
#include "mirage/viewer/stream_window.h"
#include "render_common.h"
#include "render_options.h"

namespace mirage::cli {

namespace {

std::atomic<bool> gStop{false};
extern "C" void onStopSignal(int) { gStop.store(true); }

struct ServeCliOptions {
  stream::StreamSceneOptions scene;
  stream::ServeOptions serve;
  std::string tokenFile;
  std::string codec = "h264";
  double bitrateMbit = 20.0;
  std::string bitrateScope = "link";
  std::string web;
  std::string device;
  bool quiet = false;
};

void runServe(ServeCliOptions& o) {
  if (o.tokenFile.empty()) return fail("--token-file is required: clients authenticate with its token");
  auto token = stream::readTokenFile(o.tokenFile);
  if (!token) return fail(token.error());
  o.serve.transport.token = *token;
  if (o.codec == "h264")
    o.serve.codec = stream::AtlasCodec::H264;
  else if (o.codec == "zstd")
    o.serve.codec = stream::AtlasCodec::ZstdTiles;
  else
    return fail(fmt::format("--codec {}: expected h264 or zstd", o.codec));
  if (!(o.bitrateMbit > 0.0 && o.bitrateMbit <= 1000.0)) return fail("--bitrate must be in (0, 1000] Mbit/s");
  o.serve.stream.bitrateKbps = uint32_t(o.bitrateMbit * 1000.0);
  o.serve.stream.linkBudget = o.bitrateScope == "link";
  if (o.serve.transport.certFile.empty() != o.serve.transport.keyFile.empty())
    return fail("--tls-cert and --tls-key go together");
  o.serve.transport.staticDir = o.web;
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  auto scene = stream::openStreamScene(**ctx, o.scene);
  if (!scene) return fail(scene.error());
  size_t patches = (*scene)->patches.patchCount(), triangles = (*scene)->scene.instancedTriangleCount();
  const stream::TessellationStats& tessellation = (*scene)->tessellation;
  stream::ServeLog log;
  if (!o.quiet) log = [](const std::string& line) { fmt::print("{}\n", line), std::fflush(stdout); };
  auto server = stream::StreamServer::start(**ctx, std::move(*scene), o.serve, log);
  if (!server) return fail(server.error());
  if (!o.quiet)
    fmt::print("serving {} ({} triangles, {} after tessellation to edges <= {:g}, in {} patches) on {}://{}:{}/ from "
               "{}\n",
               o.scene.input, tessellation.trianglesBefore, triangles, tessellation.maxPatchEdge, patches,
               o.serve.transport.certFile.empty() ? "ws" : "wss", o.serve.transport.host, (*server)->port(),
               (*ctx)->caps().name),
        std::fflush(stdout);
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
  Status s = (*server)->run(gStop);
  if (!s) return fail(s.error());
  if (!o.quiet) fmt::print("server stopped\n");
}

struct ClientCliOptions {
  stream::StreamClientOptions client;
  std::string path = "orbit:8";
  std::string record;
  std::string size = "1280x720";
  std::string device;
  std::string codec = "any";
  StereoOptions stereo;
  std::string present = "fifo";
  uint32_t frames = 0;
  uint32_t minServerFrames = 0;
  uint32_t posesInFlight = 2;
  CLI::Option* pathOption = nullptr;
  bool simulate = false; // --latency-ms given: open loop under a simulated network
  stream::SimulatedClientOptions simulation;
};

// One line per camera of the open-loop client, and the means at the end.
struct SimulatedReport {
  size_t frames = 0, lost = 0, withFrames = 0;
  double roundTrip = 0, inFlight = 0, bytes = 0;

  void add(const stream::ClientFrameInfo& info) {
    fmt::print("camera {:4}: {} frame(s) arrived{}, {} in flight, {:.1f} KB, server frame {}, {} patches{}\n",
               info.index, info.framesApplied,
               info.framesApplied ? fmt::format(" (round trip {:.1f} ms)", info.roundTripMs) : "", info.framesInFlight,
               info.frameBytes / 1e3, info.serverFrame, info.patchesHeld, info.poseLost ? ", pose lost" : "");
    ++frames;
    lost += info.poseLost;
    inFlight += info.framesInFlight;
    bytes += double(info.frameBytes);
    if (info.framesApplied) {
      ++withFrames;
      roundTrip += info.roundTripMs;
    }
  }
  void summary(const std::string& url) const {
    double n = frames ? double(frames) : 1.0;
    fmt::print("{} cameras from {}: mean round trip {:.1f} ms ({} cameras with a new frame), mean {:.2f} frames in "
               "flight, mean {:.1f} KB per camera, {} poses lost\n",
               frames, url, withFrames ? roundTrip / double(withFrames) : 0.0, withFrames, inFlight / n,
               bytes / n / 1e3, lost);
  }
};

void runSimulatedClient(ClientCliOptions& o, gpu::Context& ctx) {
  SimulatedReport report;
  auto sink = [&](const stream::ClientFrameInfo& info, const render::RenderOutput& out) -> Status {
    report.add(info);
    if (o.record.empty()) return Ok{};
    return io::writePng(render::pathFrameName(o.record, info.index), out.srgb);
  };
  Status s = stream::runSimulatedPathClient(ctx, o.client, o.path, o.simulation, sink);
  if (!s) return fail(s.error());
  report.summary(o.client.url);
}

void runClient(ClientCliOptions& o) {
  if (auto s = parseSize(o.size, o.client.width, o.client.height); !s) return fail(s.error());
  if (o.codec == "h264")
    o.client.capabilities = stream::kCapabilityH264;
  else if (o.codec == "zstd")
    o.client.capabilities = stream::kCapabilityZstdTiles;
  else if (o.codec == "jpeg")
    o.client.capabilities = stream::kCapabilityJpegTiles;
  else if (o.codec != "any")
    return fail(fmt::format("--codec {}: expected any, h264, zstd or jpeg", o.codec));
  o.client.stereoIpd = o.stereo.ipdOrNone();
  if (o.client.stereoIpd)
    if (auto s = render::validateIpd(*o.client.stereoIpd); !s) return fail(s.error());
  if (o.record.empty() && o.pathOption->count() == 0 && !o.simulate) { // the window
    viewer::StreamWindowOptions w;
    w.client = o.client;
    w.present = o.present;
    w.device = o.device;
    w.maxFrames = o.frames;
    w.minServerFrames = o.minServerFrames;
    w.maxPosesInFlight = o.posesInFlight;
    auto r = viewer::runStreamWindow(w);
    if (!r) return fail(r.error());
    return;
  }
  if (!o.record.empty())
    if (auto s = checkOutputPath(o.record, {".png"}); !s) return fail(s.error());
  auto ctx = openDevice(o.device);
  if (!ctx) return fail(ctx.error());
  if (o.simulate) return runSimulatedClient(o, **ctx);
  size_t written = 0;
  uint64_t bytes = 0;
  double roundTrip = 0;
  auto sink = [&](const stream::ClientFrameInfo& info, const render::RenderOutput& out) -> Status {
    bytes += info.frameBytes;
    roundTrip += info.roundTripMs;
    if (o.record.empty()) return Ok{};
    if (auto s = io::writePng(render::pathFrameName(o.record, info.index), out.srgb); !s) return s;
    ++written;
    return Ok{};
  };
  Status s = stream::runPathClient(**ctx, o.client, o.path, sink);
  if (!s) return fail(s.error());
  fmt::print("{} frames from {}: {:.2f} MB, mean round trip {:.1f} ms{}\n", written, o.client.url, bytes / 1e6,
             written ? roundTrip / double(written) : 0.0, o.record.empty() ? "" : fmt::format(", images {}", o.record));
}

} // namespace

void bindTessellation(CLI::App& cmd, stream::TessellationConfig& config) {
  cmd.add_option("--max-patch-edge", config.maxPatchEdge,
                 fmt::format("Split triangles to edges of at most this many world units before patches are built "
                             "(0: the scene's diagonal / {:g}; inf: no tessellation)",
                             stream::kPatchEdgeDivisions))
      ->capture_default_str();
  cmd.add_option("--max-triangles", config.maxTriangles,
                 "Refuse a scene that tessellation takes past this many triangles")
      ->capture_default_str();
}

void bindVisibility(CLI::App& cmd, render::AtlasVisibilityMethod& method) {
  cmd.add_option_function<std::string>(
         "--visibility",
         [&method](const std::string& text) {
           method = parseNamed(text, "--visibility", render::kAtlasVisibilityMethodNames).value();
         },
         "How the server finds the visible patches: auto (compute where the GPU has 64-bit atomics), compute "
         "(compute raster) or hardware (depth prepass and marking draws)")
      ->check(CLI::IsMember({"auto", "compute", "hardware"}))
      ->default_str("auto");
}

void bindEncoding(CLI::App& cmd, uint32_t& workers, uint32_t& threads) {
  cmd.add_option("--encode-workers", workers,
                 "Threads encoding frames while the GPU prepares the next client's (0: a quarter of the "
                 "processors, 2..8)")
      ->check(CLI::Range(0u, 64u))
      ->capture_default_str();
  cmd.add_option("--encoder-threads", threads, "H.264: slice threads of each client's encoder (0: x264 picks)")
      ->check(CLI::Range(0u, 128u))
      ->capture_default_str();
}

void bindParticles(CLI::App& cmd, std::string& effect, stream::ParticlePatches& patches) {
  cmd.add_option("--particles", effect, "A particle effect (.toml) streamed with the scene (docs/particles.md)");
  cmd.add_option_function<std::string>(
         "--particle-patches",
         [&patches](const std::string& text) {
           patches = parseNamed(text, "--particle-patches", stream::kParticlePatchesNames).value();
         },
         "--particles: atlas blocks per look of the texture sheets (merged: texture merging) or per visible "
         "particle (each)")
      ->check(CLI::IsMember({"merged", "each"}))
      ->default_str("merged");
}

void addStreamCommands(CLI::App& app) {
  auto* s = app.add_subcommand("serve", "Serve a scene by Shading Atlas Streaming (docs/stream.md)");
  auto so = std::make_shared<ServeCliOptions>();
  s->add_option("input", so->scene.input, "Scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]")->required();
  s->add_option("--port", so->serve.transport.port, "TCP port (0: any free one)")->capture_default_str();
  s->add_option("--host", so->serve.transport.host, "Address to listen on (0.0.0.0: every interface)")
      ->capture_default_str();
  s->add_option("--token-file", so->tokenFile, "File holding the token clients must send")->required();
  s->add_option("--tls-cert", so->serve.transport.certFile, "PEM certificate: serve wss:// and https://");
  s->add_option("--tls-key", so->serve.transport.keyFile, "PEM private key of --tls-cert");
  s->add_option("--max-clients", so->serve.transport.maxClients, "Connections at once")->capture_default_str();
  s->add_option("--codec", so->codec, "Atlas codec for clients that decode it: h264 or zstd (lossless)")
      ->capture_default_str();
  s->add_option("--bitrate", so->bitrateMbit, "H.264 target, Mbit/s per client")->capture_default_str();
  s->add_option("--bitrate-scope", so->bitrateScope, kBitrateScopeHelp)
      ->check(CLI::IsMember({"link", "video"}))
      ->capture_default_str();
  s->add_option("--level-bias", so->serve.stream.levelBias,
                "Atlas texels per pixel: block side x 2^bias (> 0 sharper, more bytes)")
      ->capture_default_str();
  s->add_option("--atlas-size", so->scene.atlasSize, "Atlas side in texels (power of two)")->capture_default_str();
  bindEncoding(*s, so->serve.encodeWorkers, so->serve.stream.encoderThreads);
  bindVisibility(*s, so->scene.visibility);
  s->add_option("--atlas-fill", so->serve.stream.atlasFill, kAtlasFillHelp)
      ->check(CLI::Range(0.0f, 1.0f))
      ->capture_default_str();
  s->add_option("--position-bits", so->scene.positionBits,
                "Bits per axis of the patch position grid over the scene bounds (8..24)")
      ->capture_default_str();
  s->add_option("--materials", so->scene.materials, "Material file (TOML) applied to the scene");
  bindTessellation(*s, so->scene.tessellation);
  bindParticles(*s, so->scene.particles, so->serve.stream.particlePatches);
  s->add_option("--web", so->web, "Directory of the browser client (GET / serves its index.html)");
  s->add_option("--device", so->device, "GPU index or name substring");
  s->add_flag("--quiet", so->quiet, "Print nothing but errors");
  s->callback([so] { runServe(*so); });

  auto* c = app.add_subcommand("client", "Native thin client of mirage serve (docs/stream.md)");
  auto co = std::make_shared<ClientCliOptions>();
  c->add_option("url", co->client.url, "ws://HOST:PORT/ or wss://HOST:PORT/")->required();
  c->add_option("--token", co->client.token, "The server's token")->required();
  c->add_option("--ca", co->client.caFile, "wss: PEM certificates to trust");
  co->pathOption =
      c->add_option("--path", co->path, "Camera path without a window: cams.json or orbit:N")->capture_default_str();
  c->add_option("--record", co->record, "Write the path's frames to OUT_0000.png.. (names as mirage render --path)");
  c->add_option("--size", co->size, "Viewport WxH (with --stereo: of one eye, images and window 2W x H)")
      ->capture_default_str();
  bindStereo(*c, co->stereo);
  c->add_option("--present", co->present, "Window: fifo|mailbox|immediate")->capture_default_str();
  c->add_option("--frames", co->frames, "Window: close after N display frames (0: run until closed)");
  c->add_option("--min-server-frames", co->minServerFrames,
                "Window with --frames: keep drawing until N server frames are applied too (each within the "
                "frame timeout)");
  c->add_option("--poses-in-flight", co->posesInFlight, "Window: poses sent and not yet answered, at most")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  c->add_option("--codec", co->codec, "Atlas codecs offered: any (zstd, H.264), h264, zstd or jpeg (the browser's)")
      ->capture_default_str();
  c->add_option("--device", co->device, "GPU index or name substring");
  auto* latency = c->add_option("--latency-ms", co->simulation.network.roundTripMs,
                                "Simulated network: round trip in ms (half each way); runs open loop");
  c->add_option("--jitter-ms", co->simulation.network.jitterMs,
                "Simulated network: + uniform [0, J) ms per message and direction")
      ->needs(latency);
  c->add_option("--loss", co->simulation.network.poseLoss, "Simulated network: probability a pose is lost")
      ->needs(latency);
  c->add_option("--seed", co->simulation.network.seed, "Simulated network: seed of jitter and losses")
      ->needs(latency)
      ->capture_default_str();
  c->add_option("--fps", co->simulation.fps, "Simulated network: the client's frame rate (virtual clock)")
      ->needs(latency)
      ->capture_default_str();
  c->add_option("--server-ms", co->simulation.serverMs, "Simulated network: virtual time the server takes per pose")
      ->needs(latency);
  c->callback([co, latency] {
    co->simulate = latency->count() > 0;
    runClient(*co);
  });
}

} // namespace mirage::cli
