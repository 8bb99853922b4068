#include "mirage/viewer/viewer.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <filesystem>
#include <optional>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <fmt/format.h>
#include <imgui.h>

#include "mirage/gpu/swapchain.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/render_size.h"
#include "mirage/viewer/fly_camera.h"
#include "frame_log.h"
#include "keys.h"
#include "overlay_renderer.h"
#include "overlay_ui.h"
#include "present.h"
#include "presenter.h"
#include "scene_view.h"
#include "window.h"

namespace mirage::viewer {

namespace {

Status checkPng(const std::string& path) {
  std::filesystem::path p = path;
  std::error_code ec;
  if (p.extension() != ".png") return makeError(path, "unsupported output extension (expected .png)");
  if (!p.parent_path().empty() && !std::filesystem::is_directory(p.parent_path(), ec))
    return makeError(path, "output folder does not exist");
  return Ok{};
}

// "mirage_view_0003.png": the first name of that pattern not taken in the current folder.
std::string freeName(const char* stem, const char* extension) {
  for (int i = 0;; ++i) {
    std::string name = fmt::format("{}_{:04}{}", stem, i, extension);
    std::error_code ec;
    if (!std::filesystem::exists(name, ec)) return name;
  }
}

gpu::PresentMode vsyncMode(bool vsync, gpu::PresentMode requested) {
  if (vsync) return gpu::PresentMode::Fifo;
  return requested == gpu::PresentMode::Fifo ? gpu::PresentMode::Immediate : requested;
}

// The options against each other and against the scene's kind, before any GPU or window.
Status checkOptions(const ViewerOptions& o, runtime::SceneKind kind) {
  if (auto st = runtime::validate(o.config); !st) return st;
  if (o.stereoIpd)
    if (auto st = render::validateIpd(*o.stereoIpd); !st) return st;
  if (o.frameTime)
    if (auto st = runtime::validate(*o.frameTime); !st) return st;
  if (kind != runtime::SceneKind::ClusterLod) {
    if (o.frameTime) return makeError(o.scene, "--target-ms applies to .mrg cluster-LOD assets only");
    if (o.clusterLodFlags)
      return makeError(o.scene, "--tau, --raster, --hybrid-threshold, --blend-queue-pixels, --occlusion, --cones, "
                                "--selection, --blend-raster and --fovea apply to .mrg cluster-LOD assets only");
  }
  if (o.surfelFlags && !o.surfels) return Error{"--surfel-size and --surfel-raster need --surfels"};
  return Ok{};
}

} // namespace

Status runViewer(const ViewerOptions& o) {
  // Everything checkable without a display first: a bad scene fails before any window opens.
  uint32_t width = 0, height = 0; // per eye with --stereo
  if (auto st = render::parseRenderSize(o.size, width, height); !st) return st;
  auto present = gpu::parsePresentMode(o.present);
  if (!present) return present.error();
  std::optional<render::Camera> startCamera;
  if (!o.camera.empty()) {
    auto c = render::parseCamera(o.camera);
    if (!c) return c.error();
    startCamera = *c;
  }
  if (!o.camera.empty() && !o.path.empty()) return Error{"give --camera or --path, not both"};
  if (o.exitAfterPath && o.path.empty()) return Error{"--exit-after-path needs --path"};
  if (!o.screenshot.empty()) {
    if (o.path.empty()) return Error{"--screenshot needs --path (F12 takes screenshots interactively)"};
    if (auto st = checkPng(o.screenshot); !st) return st;
  }
  auto script = parseKeyScript(o.keys);
  if (!script) return script.error();
  const SceneOptions sceneOptions{.path = o.scene,
                                  .pvs = o.pvs,
                                  .surfels = o.surfels,
                                  .materials = o.materials,
                                  .gpuBudget = o.gpuBudget,
                                  .bandwidth = o.bandwidth};
  auto kind = SceneView::check(sceneOptions);
  if (!kind) return kind.error();
  if (auto st = checkOptions(o, *kind); !st) return st;

  auto system = WindowSystem::start();
  if (!system) {
    // No display: a scene that fails to load still reports its own error (the one to fix first).
    gpu::ContextOptions headless;
    headless.device = o.device;
    if (auto c = gpu::Context::create(headless))
      if (auto s = SceneView::open(**c, sceneOptions); !s) return s.error();
    return system.error();
  }
  gpu::ContextOptions co;
  co.device = o.device;
  co.instanceExtensions = (*system)->instanceExtensions();
  co.swapchain = true;
  auto context = gpu::Context::create(co);
  if (!context) return context.error();
  // The scene opens before the window: a scene that fails to load exits with no window shown.
  auto scene = SceneView::open(**context, sceneOptions);
  if (!scene) return scene.error();
  SceneView& sceneView = **scene;
  float aspect = float(width) / float(height); // of one eye
  std::vector<render::Camera> path;
  if (!o.path.empty()) {
    auto p = render::cameraPathArgument(o.path, sceneView.bounds(), aspect);
    if (!p) return p.error();
    path = std::move(*p);
  }

  UiState ui;
  ui.config = o.config;
  ui.vsync = *present == gpu::PresentMode::Fifo;
  ui.clusterLod = sceneView.clusterLod();
  ui.hasSurfels = sceneView.hasSurfels();
  ui.hasPvs = sceneView.hasPvs();
  ui.hasBlend = sceneView.hasBlend();
  ui.mixed = sceneView.mixed();
  ui.stereoIpd = o.stereoIpd.value_or(0.0f);
  std::optional<runtime::FrameTimeState> frameTime;
  if (o.frameTime) {
    ui.targetMs = o.frameTime->targetMs;
    ui.holdTarget = true;
    frameTime = runtime::startFrameTime(*o.frameTime, ui.config);
    runtime::applyFrameTime(*o.frameTime, *frameTime, ui.config);
  }
  FlyCamera fly = startCamera ? fromCamera(*startCamera, sceneView.bounds()) : frameScene(sceneView.bounds(), aspect);
  // The first frame renders before the window opens too: settings the scene or the device cannot
  // draw (a raster backend it lacks, --stereo with BLEND materials, ...) fail with no window shown.
  {
    View first{.camera = path.empty() ? toCamera(fly) : path[0],
               .width = width,
               .height = height,
               .config = ui.config,
               .stereoIpd = o.stereoIpd};
    if (auto f = sceneView.render(first); !f) return f.error();
  }

  std::string title = "mirage view: " + std::filesystem::path(o.scene).filename().string();
  auto window = Window::create(o.stereoIpd ? 2 * width : width, height, title);
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
  // Frames in flight from the scene to the swapchain when the device blits.
  presenter.blit = createTargetBlit(**context, presenter.swapchain->format());
  const bool gpuPresent = presenter.blit.format != VK_FORMAT_UNDEFINED;
  Window& win = **window;

  std::vector<render::Camera> recorded;
  size_t replayIndex = 0;
  bool replaying = !path.empty();
  bool looking = false;                     // right button held since a press outside the overlay
  bool writingPath = !o.screenshot.empty(); // the --path replay writes OUT_NNNN.png; later replays do not
  ViewConfig lastGood = ui.config;
  bool untried = false; // the overlay changed a setting no frame has rendered with yet
  FrameStats stats;
  auto last = Clock::now();
  auto start = last;
  uint64_t frames = 0;
  // A collected frame: its stats for the overlay, its GPU time for the controller (drawn at `tau`).
  auto onStats = [&](FrameStats s, float tau) {
    double ms = gpuFrameMs(s);
    if (frameTime && ui.holdTarget && ms > 0.0) runtime::updateFrameTime(*o.frameTime, *frameTime, tau, ms);
    stats = std::move(s);
  };
  auto setPresentMode = [&] { presenter.swapchain->setPresentMode(vsyncMode(ui.vsync, *present)); };

  while (!win.shouldClose()) {
    win.poll();
    const double inputSeconds = presenter.now();
    presenter.pollCompleted();
    auto now = Clock::now();
    float seconds = std::chrono::duration<float>(now - last).count();
    last = now;
    double ms = seconds * 1000.0;
    if (frames > 0) presenter.log.frameMs.push_back(ms);
    ui.cpuFrameMs = frames == 0 ? ms : 0.9 * ui.cpuFrameMs + 0.1 * ms;
    ui.inputToSubmitMs = recentMean(presenter.log.inputToSubmitMs);
    ui.submitToGpuMs = recentMean(presenter.log.submitToGpuMs);
    ui.inputToPresentMs = recentMean(presenter.log.inputToPresentMs);

    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const ImGuiIO& io = ImGui::GetIO();
    bool screenshot = false;
    VkExtent2D extent = win.framebufferSize();
    // One eye's size: the window holds both eyes side by side with --stereo.
    VkExtent2D eye{o.stereoIpd ? extent.width / 2 : extent.width, extent.height};
    for (Action action : frameActions(win.input(), io.WantCaptureKeyboard, *script, frames)) {
      switch (action) {
      case Action::Close:
        win.requestClose();
        break;
      case Action::FrameScene: {
        float speed = fly.speed;
        fly = frameScene(sceneView.bounds(), eye.height && eye.width ? float(eye.width) / float(eye.height) : aspect,
                         fly.fovYDegrees);
        fly.speed = speed;
        break;
      }
      case Action::CopyCamera:
        ui.camera = render::formatCamera(toCamera(fly));
        ImGui::SetClipboardText(ui.camera.c_str()); // through GLFW: paste it after --camera
        fmt::print("--camera {}\n", ui.camera);
        std::fflush(stdout);
        break;
      case Action::Record:
        ui.recording = !ui.recording;
        if (ui.recording) {
          recorded.clear();
        } else if (!recorded.empty()) {
          std::string name = freeName("mirage_path", ".json");
          auto st = render::writeCameraPath(name, recorded);
          ui.message = st ? fmt::format("wrote {} ({} cameras)", name, recorded.size()) : st.error().message;
          fmt::print("{}\n", ui.message);
          path = recorded;
        }
        break;
      case Action::Replay:
        if (!path.empty()) {
          replaying = true;
          replayIndex = 0;
        }
        break;
      case Action::Screenshot:
        screenshot = true;
        break;
      case Action::Vsync:
      case Action::Transparency:
      case Action::Surfels:
        if (applySwitch(action, ui)) {
          untried = true;
          setPresentMode();
        }
        break;
      }
    }
    if (!replaying) {
      flyStep(win.input(), io.WantCaptureKeyboard, io.WantCaptureMouse, seconds, looking, fly);
      win.setCursorCaptured(looking);
    }

    // This frame's camera: the path while replaying (the fly camera follows it), else the fly camera.
    size_t pathIndex = replayIndex;
    render::Camera camera = toCamera(fly);
    if (replaying) {
      camera = path[replayIndex];
      float speed = fly.speed;
      fly = fromCamera(camera, sceneView.bounds());
      fly.speed = speed;
    }
    if (ui.recording) recorded.push_back(camera);
    ui.recorded = recorded.size();
    ui.replaying = replaying;

    if (eye.width == 0 || eye.height == 0) { // minimized: nothing to draw until restored
      ImGui::EndFrame();
      win.waitEvents();
      continue;
    }
    if (frameTime && ui.holdTarget) {
      runtime::applyFrameTime(*o.frameTime, *frameTime, ui.config);
      presenter.log.tau.push_back(ui.config.tauPixels);
    }
    View v;
    v.camera = camera;
    v.config = ui.config;
    v.stereoIpd = o.stereoIpd;
    auto advanceReplay = [&] {
      if (replaying && ++replayIndex >= path.size()) {
        replaying = false;
        replayIndex = 0;
        writingPath = false;
        if (o.exitAfterPath) win.requestClose();
      }
    };
    auto overlayPanel = [&] {
      bool held = ui.holdTarget;
      if (drawOverlayPanel(ui, stats)) {
        untried = true;
        setPresentMode();
        if (frameTime && ui.holdTarget && !held) frameTime = runtime::startFrameTime(*o.frameTime, ui.config);
      }
      ImGui::Render();
    };

    if (gpuPresent && !(replaying && writingPath) && !screenshot) {
      // Frames in flight: the scene records into the swapchain frame's command buffer, a blit takes
      // its colour target to the swapchain image, the overlay follows: one submit, no readback. The
      // stats shown are those of the frame this slot held before (framesInFlight - 1 frames late).
      auto sf = presenter.begin(extent);
      if (!sf) {
        ImGui::EndFrame();
        continue;
      }
      slotCompleted(presenter.blit, sf->slot);
      if (auto s = presenter.collect(sceneView, sf->slot)) onStats(std::move(*s), presenter.pendingTau[sf->slot]);
      v.width = o.stereoIpd ? sf->extent.width / 2 : sf->extent.width;
      v.height = sf->extent.height;
      Status sceneRecorded = v.width > 0 ? sceneView.record(sf->cmd, v, sf->slot) : Status(Error{"window too narrow"});
      std::optional<Error> fatal;
      if (sceneRecorded) {
        presenter.pending[sf->slot] = true;
        presenter.pendingTau[sf->slot] = v.config.tauPixels;
        lastGood = ui.config;
        untried = false;
        cmdBlitTargetToSwapchain(**context, presenter.blit, *sf, *sceneView.colorTarget());
      } else {
        // Nothing recorded: a black frame, then the error (or back to the last good setting).
        cmdCopyFrameToSwapchain(**context, presenter.staging, *sf, presenter.swapchain->format(), ImageRGBA8{});
        if (!untried) {
          fatal = sceneRecorded.error();
        } else {
          ui.message = sceneRecorded.error().message;
          fmt::print(stderr, "mirage: {}\n", ui.message);
          ui.config = lastGood;
          untried = false;
        }
      }
      if (!fatal) advanceReplay();
      overlayPanel();
      presenter.finish(*sf, inputSeconds);
      if (fatal) return *fatal;
      ++frames;
      if (o.maxFrames && frames >= o.maxFrames) win.requestClose();
      continue;
    }

    // Readback path: the scene renders and waits, the image goes through the CPU (PNG frames).
    presenter.drain(sceneView, onStats);
    // A recorded path renders at --size so its images match `mirage render --path` exactly.
    v.width = replaying && writingPath ? width : eye.width;
    v.height = replaying && writingPath ? height : eye.height;
    auto frame = sceneView.render(v);
    if (!frame) {
      if (!untried) {
        ImGui::EndFrame();
        return frame.error();
      }
      ui.message = frame.error().message; // a setting the device lacks: back to the last good one
      fmt::print(stderr, "mirage: {}\n", ui.message);
      ui.config = lastGood;
      untried = false;
      ImGui::EndFrame();
      continue;
    }
    lastGood = ui.config;
    untried = false;
    if (double gms = gpuFrameMs(frame->stats); gms >= 0.0) presenter.log.gpuFrameMs.push_back(gms);
    onStats(frame->stats, v.config.tauPixels);
    if (replaying && writingPath) {
      std::string name = render::pathFrameName(o.screenshot, pathIndex);
      if (auto st = io::writePng(name, frame->srgb); !st) {
        ImGui::EndFrame();
        return st.error();
      }
    }
    if (screenshot) {
      std::string name = freeName("mirage_view", ".png");
      auto st = io::writePng(name, frame->srgb);
      ui.message = st ? "wrote " + name : st.error().message;
      fmt::print("{}\n", ui.message);
    }
    advanceReplay();
    overlayPanel();
    presenter.show(win, frame->srgb, inputSeconds);
    ++frames;
    if (o.maxFrames && frames >= o.maxFrames) win.requestClose();
  }
  // How to measure the viewer (docs/viewer.md): frames per second of the whole loop (record or
  // render, blit or readback and upload, overlay, present), frame time and latency, and the
  // renderer's median GPU frame time.
  presenter.swapchain->waitIdle();
  presenter.pollCompleted();
  double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  fmt::print("{}\n", summaryLine(presenter.log, frames, seconds, (*context)->caps().name));
  return Ok{};
}

} // namespace mirage::viewer
