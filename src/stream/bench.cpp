// `mirage bench stream` (bench.h; docs/stream.md, "Measurements").
#include "mirage/stream/bench.h"

#include <algorithm>
#include <chrono>
#include <deque>

#include <fmt/format.h>

#include "mirage/core/image_metrics.h"
#include "mirage/particles/render.h"
#include "mirage/runtime/scene.h"
#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"

namespace mirage::stream {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

Status validate(const StreamBenchConfig& c) {
  if (c.clients < 1 || c.clients > 64) return Error{"--clients must be in 1..64"};
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
  cc.particlePatches = c.particlePatches;
  std::vector<std::unique_ptr<ClientStream>> clients;
  for (uint32_t k = 0; k < c.clients; ++k) {
    auto client = ClientStream::create(served, cc);
    if (!client) return client.error();
    clients.push_back(std::move(*client));
  }
  auto view = StreamView::create(context, sceneWelcome(served, c.codec));
  if (!view) return view.error();
  std::unique_ptr<runtime::Scene> local;
  if (c.quality) {
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
  // Client 0's frames on their way: each arrives latencyFrames after the pose it answers was sent.
  std::deque<std::pair<size_t, Frame>> inFlight;
  std::vector<uint32_t> sequences(c.clients, 0);
  double qualityFrames = 0;
  uint64_t bytes = 0;
  report.minSsim = 1.0;
  for (size_t i = 0; i < n; ++i) {
    StreamBenchFrame f;
    for (uint32_t k = 0; k < c.clients; ++k) {
      size_t j = (i + size_t(k) * n / c.clients) % n; // each client at its own place on the path
      Pose pose;
      pose.sequence = ++sequences[k];
      pose.camera = toProtocolCamera(cameras[j]);
      pose.predicted = toProtocolCamera(cameras[std::min(j + c.latencyFrames, n - 1)]);
      pose.viewportWidth = c.width;
      pose.viewportHeight = c.height;
      StreamFrameStats st;
      auto frame = clients[k]->produceFrame(served, pose, &st);
      if (!frame) return frame.error();
      f.serverMs += st.totalMs / c.clients;
      f.gpuVisibilityMs += st.gpuVisibilityMs / c.clients;
      f.gpuShadingMs += st.gpuShadingMs / c.clients;
      for (const gpu::PassTime& t : st.gpuPasses) f.gpuPasses[t.name] += t.milliseconds / c.clients;
      f.encodeMs += st.encodeMs / c.clients;
      f.shadedTexels += st.shadedTexels / c.clients;
      f.visiblePatches += st.visiblePatches / c.clients;
      f.colourOnly += st.colourOnly / c.clients;
      if (k == 0) {
        f.geometryBytes = st.geometryBytes;
        f.geometryRawBytes = st.geometryRawBytes;
        f.atlasBytes = st.atlasBytes;
        f.levelBias = st.levelBias;
        f.geometryEntries = st.addedOrMoved - st.blockOnly;
        f.blockOnlyEntries = st.blockOnly;
        f.removed = st.removed;
        f.colours = st.colours;
        f.particles = st.particles;
        f.particleBytes = st.particleBytes;
        f.particleRawBytes = st.particleRawBytes;
        bytes += st.geometryBytes + st.particleBytes + st.atlasBytes;
        inFlight.emplace_back(i + c.latencyFrames, std::move(*frame));
      }
    }
    auto tApply = Clock::now();
    while (!inFlight.empty() && inFlight.front().first <= i) {
      if (auto s = (*view)->apply(inFlight.front().second); !s) return s.error();
      effectSteps = inFlight.front().second.sequence;
      inFlight.pop_front();
    }
    f.clientApplyMs = msSince(tApply);
    if (c.quality) {
      auto tRender = Clock::now();
      auto image = (*view)->render(cameras[i], c.width, c.height);
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
    }
    report.meanServerMs += f.serverMs / double(n);
    report.meanGpuMs += (f.gpuVisibilityMs + f.gpuShadingMs) / double(n);
    report.frames.push_back(f);
  }
  if (qualityFrames > 0) {
    report.meanSsim /= qualityFrames;
    report.meanPsnr /= qualityFrames;
  } else {
    report.minSsim = 0;
  }
  report.megabitsPerSecond = double(bytes) * 8.0 * c.fps / double(n) / 1e6;
  report.clientsAt30Hz = report.meanServerMs > 0 ? 1000.0 / (30.0 * report.meanServerMs) : 0.0;
  return report;
}

} // namespace mirage::stream
