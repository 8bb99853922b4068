// `mirage bench stream` (bench.h; docs/stream.md, "Measurements").
#include "mirage/stream/bench.h"

#include <algorithm>
#include <chrono>
#include <deque>
#include <future>

#include <fmt/format.h>

#include "mirage/core/image_metrics.h"
#include "mirage/particles/render.h"
#include "mirage/runtime/scene.h"
#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"

#include "frame_workers.h"

namespace mirage::stream {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

Status validate(const StreamBenchConfig& c) {
  if (c.clients < 1 || c.clients > 64) return Error{"--clients must be in 1..64"};
  if (c.encodeWorkers > 64) return Error{"--encode-workers must be in 0..64"};
  if (c.encoderThreads > 128) return Error{"--encoder-threads must be in 0..128"};
  if (c.fps < 1 || c.fps > 1000) return Error{"--fps must be in 1..1000"};
  if (c.latencyFrames > 600) return Error{"--latency-frames must be in 0..600"};
  if (c.width < 16 || c.height < 16 || c.width > 16384 || c.height > 16384)
    return Error{"--size must be 16..16384 a side"};
  if (c.codec != AtlasCodec::H264 && c.codec != AtlasCodec::ZstdTiles && c.codec != AtlasCodec::JpegTiles)
    return Error{"--codec must be h264, zstd or jpeg"};
  return Ok{};
}

} // namespace

Result<StreamBenchReport> runStreamBench(gpu::Context& context, const StreamBenchConfig& c) {
  if (auto s = validate(c); !s) return s.error();
  auto scene = openStreamScene(
      context, {c.input, c.materials, c.atlasSize, c.tessellation, c.positionBits, c.visibility, c.particles});
  if (!scene) return scene.error();
  StreamScene& served = **scene;
  auto path = render::cameraPathArgument(c.path, served.bounds, float(c.width) / float(c.height));
  if (!path) return path.error();
  const std::vector<render::Camera>& cameras = *path;
  const size_t n = cameras.size();
  if (n == 0) return Error{fmt::format("{}: no cameras", c.path)};

  ClientStreamConfig cc{c.codec, c.bitrateKbps, c.fps, c.levelBias};
  cc.atlasFill = c.atlasFill;
  cc.encoderThreads = c.encoderThreads;
  cc.particlePatches = c.particlePatches;
  cc.linkBudget = c.linkBudget;
  std::vector<std::unique_ptr<ClientStream>> clients;
  for (uint32_t k = 0; k < c.clients; ++k) {
    auto client = ClientStream::create(served, cc);
    if (!client) return client.error();
    clients.push_back(std::move(*client));
  }
  std::unique_ptr<StreamView> view;
  std::unique_ptr<runtime::Scene> local;
  if (c.quality) {
    auto created = StreamView::create(context, sceneWelcome(served, c.codec));
    if (!created) return created.error();
    view = std::move(*created);
    runtime::SceneOptions lo;
    lo.input = c.input;
    lo.materials = c.materials;
    auto opened = runtime::Scene::open(context, lo);
    if (!opened) return opened.error();
    local = std::move(*opened);
  }
  // The effect as `mirage render --particles` draws it (CPU simulation, billboards: the client's).
  std::unique_ptr<particles::EffectPlayer> effect;
  uint32_t effectSteps = 0, effectTaken = 0; // the last frame client 0 applied; the steps the player took
  if (c.quality && served.effect) {
    auto player =
        particles::EffectPlayer::create(context, *served.effect, particles::SimKind::Cpu, kStreamParticleStep);
    if (!player) return player.error();
    effect = std::move(*player);
    if (auto s = effect->draw()->setSettings({/*splatBelowPixels=*/0.0f}); !s) return s.error();
  }

  StreamBenchReport report;
  report.device = context.caps().name;
  report.visibility = served.shading->visibilityMethod();
  report.tessellation = served.tessellation;
  report.patches = served.patches.patchCount();
  report.encodeWorkers = frameWorkerCount(c.encodeWorkers);
  report.frames.resize(n);
  // Client 0's frames on their way: each arrives latencyFrames after the pose it answers was sent.
  std::deque<std::pair<size_t, Frame>> arriving;
  uint64_t bytes = 0;
  // A client frame being finished on a worker, and the path step it answers.
  struct Finished {
    Result<Frame> frame;
    StreamFrameStats stats;
  };
  std::vector<std::future<Finished>> inFlight(c.clients);
  std::vector<size_t> stepOf(c.clients, 0);
  // Declared after everything its jobs use: an early return joins the workers first.
  FrameWorkers workers(report.encodeWorkers);
  auto collect = [&](uint32_t k) -> Status {
    Finished done = inFlight[k].get();
    if (!done.frame) return done.frame.error();
    const StreamFrameStats& st = done.stats;
    StreamBenchFrame& f = report.frames[stepOf[k]];
    const double share = 1.0 / c.clients;
    f.serverMs += st.totalMs * share;
    f.visibilityMs += st.visibilityMs * share;
    f.shadingMs += st.shadingMs * share;
    f.levelsMs += st.levelsMs * share;
    f.allocateMs += st.allocateMs * share;
    f.blocksMs += st.blocksMs * share;
    f.readbackMs += st.readbackMs * share;
    f.encodeMs += st.encodeMs * share;
    f.patchesMs += st.patchesMs * share;
    f.gpuVisibilityMs += st.gpuVisibilityMs * share;
    f.gpuShadingMs += st.gpuShadingMs * share;
    f.gpuConvertMs += st.gpuConvertMs * share;
    for (const gpu::PassTime& t : st.gpuPasses) f.gpuPasses[t.name] += t.milliseconds * share;
    f.shadedTexels += st.shadedTexels / c.clients;
    f.visiblePatches += st.visiblePatches / c.clients;
    f.colourOnly += st.colourOnly / c.clients;
    if (k == 0) {
      f.geometryBytes = st.geometryBytes;
      f.geometryRawBytes = st.geometryRawBytes;
      f.atlasBytes = st.atlasBytes;
      f.videoTargetKbps = st.videoTargetKbps;
      f.levelBias = st.levelBias;
      f.geometryEntries = st.addedOrMoved - st.blockOnly;
      f.blockOnlyEntries = st.blockOnly;
      f.removed = st.removed;
      f.colours = st.colours;
      f.particles = st.particles;
      f.particleBytes = st.particleBytes;
      f.particleRawBytes = st.particleRawBytes;
      bytes += st.geometryBytes + st.particleBytes + st.atlasBytes;
      if (c.quality) arriving.emplace_back(stepOf[k] + c.latencyFrames, std::move(*done.frame));
    }
    return Ok{};
  };
  auto drain = [&]() -> Status {
    for (uint32_t k = 0; k < c.clients; ++k)
      if (inFlight[k].valid())
        if (Status s = collect(k); !s) return s;
    return Ok{};
  };

  double qualityFrames = 0;
  report.minSsim = 1.0;
  auto running = Clock::now(); // the server's clock runs from here, stopped while client 0 draws
  for (size_t i = 0; i < n; ++i) {
    for (uint32_t k = 0; k < c.clients; ++k) {
      // One frame in flight per client, as the server answers a pose once the last frame is out.
      if (inFlight[k].valid())
        if (Status s = collect(k); !s) return s.error();
      size_t j = (i + size_t(k) * n / c.clients) % n; // each client at its own place on the path
      Pose pose;
      pose.sequence = uint32_t(i + 1);
      pose.camera = toProtocolCamera(cameras[j]);
      pose.predicted = toProtocolCamera(cameras[std::min(j + c.latencyFrames, n - 1)]);
      pose.viewportWidth = c.width;
      pose.viewportHeight = c.height;
      if (Status s = clients[k]->prepareFrame(served, pose); !s) return s.error();
      stepOf[k] = i;
      inFlight[k] = workers.submit([&served, client = clients[k].get()] {
        Finished done{Error{"not finished"}, {}};
        done.frame = client->finishFrame(served, &done.stats);
        return done;
      });
    }
    if (!c.quality) continue;
    if (Status s = drain(); !s) return s.error(); // client 0's frame of this step is drawn now
    report.serverSeconds += std::chrono::duration<double>(Clock::now() - running).count();
    StreamBenchFrame& f = report.frames[i];
    auto tApply = Clock::now();
    while (!arriving.empty() && arriving.front().first <= i) {
      if (auto s = view->apply(arriving.front().second); !s) return s.error();
      effectSteps = arriving.front().second.sequence;
      arriving.pop_front();
    }
    f.clientApplyMs = msSince(tApply);
    auto tRender = Clock::now();
    auto image = view->render(cameras[i], c.width, c.height);
    if (!image) return image.error();
    f.clientRenderMs = msSince(tRender);
    runtime::View lv;
    lv.camera = cameras[i];
    if (effect) {
      effect->step(effectSteps - effectTaken);
      effectTaken = effectSteps;
      lv.particles = effect->draw();
      lv.camera = particles::clipAround(cameras[i], local->bounds(), effect->bounds());
    }
    lv.width = c.width;
    lv.height = c.height;
    auto reference = local->render(lv);
    if (!reference) return reference.error();
    f.ssim = ssim(image->srgb, reference->srgb);
    f.psnr = psnr(image->srgb, reference->srgb);
    if (i >= c.latencyFrames) {
      report.meanSsim += f.ssim;
      report.meanPsnr += std::min(f.psnr, 99.0);
      report.minSsim = std::min(report.minSsim, f.ssim);
      qualityFrames += 1;
    }
    running = Clock::now();
  }
  if (Status s = drain(); !s) return s.error();
  if (!c.quality) report.serverSeconds = std::chrono::duration<double>(Clock::now() - running).count();
  for (const StreamBenchFrame& f : report.frames) {
    report.meanServerMs += f.serverMs / double(n);
    report.meanGpuMs += (f.gpuVisibilityMs + f.gpuShadingMs + f.gpuConvertMs) / double(n);
  }
  if (qualityFrames > 0) {
    report.meanSsim /= qualityFrames;
    report.meanPsnr /= qualityFrames;
  } else {
    report.minSsim = 0;
  }
  report.megabitsPerSecond = double(bytes) * 8.0 * c.fps / double(n) / 1e6;
  report.framesPerSecond = report.serverSeconds > 0 ? double(n) * c.clients / report.serverSeconds : 0.0;
  report.clientsAt30Hz = report.framesPerSecond / 30.0;
  return report;
}

} // namespace mirage::stream
