// The stream client's window loop (stream_window.h; docs/stream.md, "The native client window and
// stereo"): the viewer's window, presenter and fly camera around a stream::StreamView.
#include "mirage/viewer/stream_window.h"

#include <deque>
#include <utility>

#include <fmt/format.h>

#include "mirage/gpu/swapchain.h"
#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"
#include "mirage/viewer/fly_camera.h"
#include "keys.h"
#include "presenter.h"

namespace mirage::viewer {

namespace {

const char* codecName(stream::AtlasCodec codec) {
  switch (codec) {
  case stream::AtlasCodec::ZstdTiles:
    return "zstd tiles (lossless)";
  case stream::AtlasCodec::H264:
    return "H.264";
  default:
    return "none";
  }
}

// The stream's figures: poses in flight, round trips, and the frames of the last second.
struct StreamFigures {
  std::deque<std::pair<uint32_t, Clock::time_point>> unanswered; // poses sent, oldest first
  std::deque<std::pair<Clock::time_point, uint64_t>> recent;     // frames received in the last second: bytes
  double roundTripMs = 0.0;                                      // smoothed
  double roundTripSum = 0.0;
  uint64_t roundTrips = 0;
  uint64_t posesSent = 0, framesApplied = 0;
  Clock::time_point lastFrame = Clock::now(); // last frame received, or the first pose sent since

  void sent(uint32_t sequence, Clock::time_point now) {
    if (unanswered.empty()) lastFrame = now; // the wait for an answer starts here
    unanswered.emplace_back(sequence, now);
    ++posesSent;
  }
  // A frame answering pose `poseSequence` (the server answers the latest pose it has, so earlier
  // unanswered ones are answered by it too; their round trip is not measured).
  void received(uint32_t poseSequence, uint64_t bytes, Clock::time_point now) {
    while (!unanswered.empty() && unanswered.front().first <= poseSequence) {
      if (unanswered.front().first == poseSequence) {
        double ms = std::chrono::duration<double, std::milli>(now - unanswered.front().second).count();
        roundTripMs = roundTrips == 0 ? ms : 0.8 * roundTripMs + 0.2 * ms;
        roundTripSum += ms;
        ++roundTrips;
      }
      unanswered.pop_front();
    }
    recent.emplace_back(now, bytes);
    lastFrame = now;
    ++framesApplied;
  }
  void expire(Clock::time_point now) {
    while (!recent.empty() && now - recent.front().first > std::chrono::seconds(1)) recent.pop_front();
  }
  double megabitsPerSecond() const {
    uint64_t bytes = 0;
    for (const auto& r : recent) bytes += r.second;
    return double(bytes) * 8.0 / 1e6;
  }
};

void drawStreamOverlay(const StreamFigures& f, const stream::StreamView& view, double displayMs, bool stereo) {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::Begin("mirage client", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::Text("display %.1f FPS (%.2f ms)%s", displayMs > 0.0 ? 1000.0 / displayMs : 0.0, displayMs,
              stereo ? ", stereo" : "");
  ImGui::Text("round trip %.1f ms, %zu poses in flight", f.roundTripMs, f.unanswered.size());
  ImGui::Text("server %zu frames/s, %.2f Mbit/s", f.recent.size(), f.megabitsPerSecond());
  ImGui::Text("patches held %zu of %u", view.patchCount(), view.welcome().patchCount);
  ImGui::Text("atlas %ux%u, %s", view.welcome().atlasWidth, view.welcome().atlasHeight,
              codecName(view.welcome().codec));
  ImGui::TextDisabled("WASD/QE move, right mouse look, F frame scene, C print camera, Esc quit");
  ImGui::End();
}

// Applies every message that arrived, without waiting. Errors: the connection closed (with the
// server's reason), a frame that does not apply (the connection is closed).
Status pollFrames(stream::TransportClient& transport, stream::StreamView& view, StreamFigures& figures,
                  const std::string& url) {
  for (;;) {
    auto message = transport.receive(std::chrono::milliseconds(0));
    if (!message) {
      if (transport.connected()) return Ok{}; // nothing more yet
      return Error{fmt::format("{}: connection lost: {}", url, message.error().message)};
    }
    if (auto* close = std::get_if<stream::Close>(&*message))
      return Error{fmt::format("{}: server closed the connection: {}", url, close->reason)};
    auto* frame = std::get_if<stream::Frame>(&*message);
    if (!frame)
      return Error{
          fmt::format("{}: unexpected {} message", url, stream::messageTypeName(stream::messageType(*message)))};
    if (auto s = view.apply(*frame); !s) {
      transport.close(stream::CloseCode::Malformed, s.error().message);
      return Error{fmt::format("{}: {}", url, s.error().message)};
    }
    figures.received(frame->poseSequence, stream::encodeMessage(*frame).size(), Clock::now());
  }
}

// The latest state drawn from `camera` and read back: one eye, or both side by side.
Result<ImageRGBA8> drawReadback(stream::StreamView& view, const render::Camera& camera, VkExtent2D eye,
                                std::optional<float> stereoIpd) {
  if (!stereoIpd) {
    auto out = view.render(camera, eye.width, eye.height);
    if (!out) return out.error();
    return std::move(out->srgb);
  }
  auto eyes = stream::clientEyes(camera, *stereoIpd);
  auto left = view.render(eyes[0], eye.width, eye.height);
  if (!left) return left.error();
  auto right = view.render(eyes[1], eye.width, eye.height);
  if (!right) return right.error();
  return stream::sideBySide(left->srgb, right->srgb);
}

} // namespace

Result<StreamWindowSummary> runStreamWindow(const StreamWindowOptions& o) {
  const stream::StreamClientOptions& co = o.client;
  if (co.width == 0 || co.height == 0) return Error{"--size: empty viewport"};
  if (co.stereoIpd)
    if (auto s = render::validateIpd(*co.stereoIpd); !s) return s.error();
  if (o.maxPosesInFlight == 0) return Error{"poses in flight: at least 1"};
  auto present = gpu::parsePresentMode(o.present);
  if (!present) return present.error();

  // Connected before anything else: a refused token or an unreachable server is the error to fix
  // first, with or without a display, and no window opens.
  stream::TransportClient transport;
  auto welcome = transport.connect(co.url, stream::transportConfig(co));
  if (!welcome) return welcome.error();
  auto system = WindowSystem::start();
  if (!system) return system.error();
  gpu::ContextOptions ctxOptions;
  ctxOptions.device = o.device;
  ctxOptions.instanceExtensions = (*system)->instanceExtensions();
  ctxOptions.swapchain = true;
  ctxOptions.validation = o.validation;
  auto context = gpu::Context::create(ctxOptions);
  if (!context) return context.error();
  auto created = stream::StreamView::create(**context, *welcome);
  if (!created) return created.error();
  stream::StreamView& view = **created;
  Bounds bounds;
  bounds.add(welcome->sceneMin);
  bounds.add(welcome->sceneMax);
  const float aspect = float(co.width) / float(co.height); // of one eye
  FlyCamera fly = frameScene(bounds, aspect);              // the orbit's first camera: render::autoCamera

  const bool stereo = co.stereoIpd.has_value();
  auto window = Window::create(stereo ? 2 * co.width : co.width, co.height, "mirage client: " + co.url);
  if (!window) return window.error();
  auto surface = (*window)->createSurface((*context)->instance());
  if (!surface) return surface.error();
  gpu::SwapchainOptions so;
  so.presentMode = *present;
  auto swapchain = gpu::Swapchain::create(**context, *surface, (*window)->framebufferSize(), so);
  if (!swapchain) return swapchain.error();
  ImGuiSession imgui((*window)->handle());
  Presenter presenter{**context, std::move(*swapchain), nullptr, {}, {}};
  presenter.overlay =
      OverlayRenderer::create(**context, presenter.swapchain->format(), presenter.swapchain->framesInFlight());
  presenter.blit = createTargetBlit(**context, presenter.swapchain->format());
  // Mono frames are recorded into the swapchain frame (frames in flight, no readback). Stereo draws
  // each eye with AtlasClientRenderer::render and shows the pair through staging: the renderer has
  // one frame record per slot, so two eyes cannot share a swapchain frame's slot.
  const bool gpuPresent = presenter.blit.format != VK_FORMAT_UNDEFINED && !stereo;
  Window& win = **window;

  auto drain = [&] { // before AtlasClientRenderer::render (slot 0, waits): the recorded frames finish
    bool any = false;
    for (bool p : presenter.pending) any = any || p;
    if (!any) return;
    presenter.swapchain->waitIdle();
    presenter.pollCompleted();
    for (uint32_t i = 0; i < gpu::kMaxFramesInFlight; ++i)
      if (presenter.pending[i]) {
        presenter.pending[i] = false;
        (void)view.renderer().collect(i);
      }
  };

  StreamFigures figures;
  StreamWindowSummary summary;
  std::vector<ScriptedKey> noScript;
  bool looking = false;
  uint32_t sequence = 0;
  render::Camera previous = toCamera(fly);
  auto last = Clock::now();
  const auto start = last;
  double displayMs = 0.0;
  uint64_t frames = 0;
  while (!win.shouldClose()) {
    win.poll();
    const double inputSeconds = presenter.now();
    presenter.pollCompleted();
    PolledInput input = win.input();
    bool finalFrame = o.maxFrames && frames + 1 >= o.maxFrames && figures.framesApplied >= o.minServerFrames;
    if (o.script && !o.script(frames, figures.framesApplied, input)) finalFrame = true;
    auto now = Clock::now();
    float seconds = std::chrono::duration<float>(now - last).count();
    last = now;
    if (frames > 0) {
      presenter.log.frameMs.push_back(seconds * 1000.0);
      displayMs = frames == 1 ? seconds * 1000.0 : 0.9 * displayMs + 0.1 * seconds * 1000.0;
    }

    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const ImGuiIO& io = ImGui::GetIO();
    VkExtent2D extent = win.framebufferSize();
    VkExtent2D eye{stereo ? extent.width / 2 : extent.width, extent.height};
    for (Action action : frameActions(input, io.WantCaptureKeyboard, noScript, frames)) {
      if (action == Action::Close) win.requestClose();
      if (action == Action::FrameScene) {
        float speed = fly.speed;
        fly = frameScene(bounds, eye.width && eye.height ? float(eye.width) / float(eye.height) : aspect,
                         fly.fovYDegrees);
        fly.speed = speed;
      }
      if (action == Action::CopyCamera) {
        std::string camera = render::formatCamera(toCamera(fly));
        ImGui::SetClipboardText(camera.c_str());
        fmt::print("--camera {}\n", camera);
        std::fflush(stdout);
      }
    }
    flyStep(input, io.WantCaptureKeyboard, io.WantCaptureMouse, seconds, looking, fly);
    win.setCursorCaptured(looking);
    const render::Camera camera = toCamera(fly);

    // The network: what arrived is applied; a pose goes out unless enough are unanswered.
    if (auto s = pollFrames(transport, view, figures, co.url); !s) {
      ImGui::EndFrame();
      return s.error();
    }
    now = Clock::now();
    figures.expire(now);
    if (!figures.unanswered.empty() && now - figures.lastFrame > co.timeout) {
      ImGui::EndFrame();
      return Error{fmt::format("{}: no frame within {} ms", co.url, co.timeout.count())};
    }
    render::Camera predicted = stream::extrapolateCamera(previous, camera, seconds, figures.roundTripMs / 1000.0);
    previous = camera;
    if (eye.width > 0 && eye.height > 0 && figures.unanswered.size() < o.maxPosesInFlight) {
      if (!transport.send(stream::clientPose(++sequence, camera, predicted, eye.width, eye.height, co.stereoIpd))) {
        ImGui::EndFrame();
        return Error{fmt::format("{}: connection lost", co.url)};
      }
      figures.sent(sequence, now);
    }

    if (eye.width == 0 || eye.height == 0) { // minimized: nothing to draw until restored
      ImGui::EndFrame();
      win.waitEvents();
      continue;
    }
    summary.camera = camera;
    const bool capture = o.captureLast && finalFrame;
    if (gpuPresent && !capture) {
      auto sf = presenter.begin(extent);
      if (!sf) {
        ImGui::EndFrame();
        continue;
      }
      slotCompleted(presenter.blit, sf->slot);
      if (presenter.pending[sf->slot]) { // its fence signalled in begin()
        presenter.pending[sf->slot] = false;
        (void)view.renderer().collect(sf->slot);
      }
      render::AtlasClientSettings settings;
      settings.width = sf->extent.width;
      settings.height = sf->extent.height;
      settings.camera = render::withClipPlanes(camera, bounds);
      settings.readImage = false;
      Status recorded = view.renderer().record(sf->cmd, settings, sf->slot);
      if (recorded) {
        presenter.pending[sf->slot] = true;
        cmdBlitTargetToSwapchain(**context, presenter.blit, *sf, view.renderer().colorTarget());
      } else {
        cmdCopyFrameToSwapchain(**context, presenter.staging, *sf, presenter.swapchain->format(), ImageRGBA8{});
      }
      drawStreamOverlay(figures, view, displayMs, stereo);
      ImGui::Render();
      presenter.finish(*sf, inputSeconds);
      if (!recorded) return recorded.error();
    } else {
      drain();
      auto image = drawReadback(view, camera, eye, co.stereoIpd);
      if (!image) {
        ImGui::EndFrame();
        return image.error();
      }
      drawStreamOverlay(figures, view, displayMs, stereo);
      ImGui::Render();
      presenter.show(win, *image, inputSeconds);
      if (capture) summary.last = std::move(*image);
    }
    ++frames;
    if (finalFrame) win.requestClose();
  }
  presenter.swapchain->waitIdle();
  presenter.pollCompleted();
  drain();
  transport.close();
  double total = std::chrono::duration<double>(Clock::now() - start).count();
  summary.displayFrames = frames;
  summary.posesSent = figures.posesSent;
  summary.serverFrames = figures.framesApplied;
  summary.patchesHeld = view.patchCount();
  summary.validationIssues = (*context)->validationIssues();
  summary.meanRoundTripMs = figures.roundTrips ? figures.roundTripSum / double(figures.roundTrips) : 0.0;
  fmt::print("{}\n", summaryLine(presenter.log, frames, total, (*context)->caps().name));
  fmt::print("stream {}: {} poses sent, {} frames applied, mean round trip {:.1f} ms, {} patches held, {}\n", co.url,
             summary.posesSent, summary.serverFrames, summary.meanRoundTripMs, summary.patchesHeld,
             codecName(welcome->codec));
  return summary;
}

} // namespace mirage::viewer
