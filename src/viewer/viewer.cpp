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
#include "overlay_renderer.h"
#include "overlay_ui.h"
#include "present.h"
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

// Dear ImGui's context with the GLFW input backend (no imgui.ini is written).
struct ImGuiSession {
  explicit ImGuiSession(GLFWwindow* window) {
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForVulkan(window, true);
  }
  ~ImGuiSession() {
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
};

// Everything the loop owns on the GPU side, destroyed after the device went idle.
struct Presenter {
  gpu::Context& context;
  std::unique_ptr<gpu::Swapchain> swapchain;
  std::unique_ptr<OverlayRenderer> overlay;
  PresentStaging staging;
  TargetBlit blit;
  // Swapchain slots whose scene frame was recorded and not yet collected (the scene's slots are the
  // swapchain's: both counts are 3 at most).
  bool pending[gpu::kMaxFramesInFlight] = {};
  static_assert(gpu::kMaxFramesInFlight <= render::kMaxFramesInFlight);
  ~Presenter() {
    if (swapchain) swapchain->waitIdle();
  }
  // Readback path: shows `image` with the overlay (ImGui::Render done) when the swapchain gives an image.
  void show(const Window& window, const ImageRGBA8& image) {
    auto frame = swapchain->beginFrame(window.framebufferSize());
    if (!frame) return;
    slotCompleted(blit, frame->slot);
    cmdCopyFrameToSwapchain(context, staging, *frame, swapchain->format(), image);
    finish(*frame);
  }
  // The overlay (ImGui::Render done), then submit and present.
  void finish(const gpu::Swapchain::Frame& frame) {
    overlay->record(frame.cmd, frame.slot, frame.view, frame.extent, ImGui::GetDrawData());
    cmdTransitionForPresent(frame.cmd, frame.image);
    swapchain->endFrame(frame);
  }
  // The stats of slot `slot`'s recorded frame, if it holds one (its fence signalled).
  void collect(SceneView& scene, uint32_t slot, FrameStats& stats, std::vector<double>& gpuFrameMs) {
    if (!pending[slot]) return;
    pending[slot] = false;
    auto collected = scene.collect(slot);
    if (!collected) return;
    stats = std::move(*collected);
    for (const gpu::PassTime& t : stats.passTimes)
      if (t.name == "frame") gpuFrameMs.push_back(t.milliseconds);
  }
  // Before a frame through Scene::render (it uses slot 0 and waits): the frames in flight finish
  // and give their stats. Rare: frames written to PNG, scenes switching paths never.
  void drain(SceneView& scene, FrameStats& stats, std::vector<double>& gpuFrameMs) {
    bool any = false;
    for (bool p : pending) any = any || p;
    if (!any) return;
    swapchain->waitIdle();
    for (uint32_t i = 0; i < gpu::kMaxFramesInFlight; ++i) collect(scene, i, stats, gpuFrameMs);
  }
};

gpu::PresentMode vsyncMode(bool vsync, gpu::PresentMode requested) {
  if (vsync) return gpu::PresentMode::Fifo;
  return requested == gpu::PresentMode::Fifo ? gpu::PresentMode::Immediate : requested;
}

} // namespace

Status runViewer(const ViewerOptions& o) {
  // Everything checkable without a display first: a bad scene fails before any window opens.
  uint32_t width = 0, height = 0;
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
  if (o.exitAfterPath && (o.path.empty() || o.screenshot.empty()))
    return Error{"--exit-after-path needs --path and --screenshot"};
  if (!o.screenshot.empty()) {
    if (o.path.empty()) return Error{"--screenshot needs --path (F12 takes screenshots interactively)"};
    if (auto st = checkPng(o.screenshot); !st) return st;
  }
  const SceneOptions sceneOptions{.path = o.scene, .pvs = o.pvs, .surfels = o.surfels};
  if (auto st = SceneView::check(sceneOptions); !st) return st;

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
  float aspect = float(width) / float(height);
  std::vector<render::Camera> path;
  if (!o.path.empty()) {
    auto p = render::cameraPathArgument(o.path, sceneView.bounds(), aspect);
    if (!p) return p.error();
    path = std::move(*p);
  }

  auto window = Window::create(width, height, "mirage view: " + std::filesystem::path(o.scene).filename().string());
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
  // Frames in flight from the scene to the swapchain when the scene records and the device blits.
  presenter.blit = createTargetBlit(**context, presenter.swapchain->format());
  const bool gpuPresent = sceneView.canRecord() && presenter.blit.format != VK_FORMAT_UNDEFINED;
  Window& win = **window;

  UiState ui;
  ui.vsync = *present == gpu::PresentMode::Fifo;
  ui.clusterLod = sceneView.clusterLod();
  ui.hasSurfels = sceneView.hasSurfels();
  ui.hasPvs = sceneView.hasPvs();
  FlyCamera fly = startCamera ? fromCamera(*startCamera, sceneView.bounds()) : frameScene(sceneView.bounds(), aspect);
  std::vector<render::Camera> recorded;
  size_t replayIndex = 0;
  bool replaying = !path.empty();
  bool looking = false;                     // right button held since a press outside the overlay
  bool writingPath = !o.screenshot.empty(); // the --path replay writes OUT_NNNN.png; later replays do not
  ViewConfig lastGood = ui.config;
  bool untried = false; // the overlay changed a setting no frame has rendered with yet
  FrameStats stats;
  auto last = std::chrono::steady_clock::now();
  auto start = last;
  uint64_t frames = 0;
  std::vector<double> gpuFrameMs; // per frame: the renderer's "frame" pass

  while (!win.shouldClose()) {
    win.poll();
    auto now = std::chrono::steady_clock::now();
    float seconds = std::chrono::duration<float>(now - last).count();
    last = now;
    double ms = seconds * 1000.0;
    ui.cpuFrameMs = frames == 0 ? ms : 0.9 * ui.cpuFrameMs + 0.1 * ms;

    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const ImGuiIO& io = ImGui::GetIO();
    bool keys = !io.WantCaptureKeyboard;
    bool screenshot = false;
    if (keys) {
      if (win.keyPressed(GLFW_KEY_ESCAPE)) win.requestClose();
      if (win.keyPressed(GLFW_KEY_F)) {
        VkExtent2D e = win.framebufferSize();
        float speed = fly.speed;
        fly = frameScene(sceneView.bounds(), e.height ? float(e.width) / float(e.height) : aspect, fly.fovYDegrees);
        fly.speed = speed;
      }
      if (win.keyPressed(GLFW_KEY_C)) {
        ui.camera = render::formatCamera(toCamera(fly));
        ImGui::SetClipboardText(ui.camera.c_str()); // through GLFW: paste it after --camera
        fmt::print("--camera {}\n", ui.camera);
        std::fflush(stdout);
      }
      if (win.keyPressed(GLFW_KEY_R)) {
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
      }
      if (win.keyPressed(GLFW_KEY_P) && !path.empty()) {
        replaying = true;
        replayIndex = 0;
      }
      if (win.keyPressed(GLFW_KEY_F12)) screenshot = true;
    }
    if (!replaying) {
      FlyInput in;
      if (keys)
        in.move = moveAxes(win.keyDown(GLFW_KEY_W), win.keyDown(GLFW_KEY_A), win.keyDown(GLFW_KEY_S),
                           win.keyDown(GLFW_KEY_D), win.keyDown(GLFW_KEY_Q), win.keyDown(GLFW_KEY_E));
      // Looking starts with a right press outside the overlay and lasts while the button is held;
      // the cursor is hidden and unbounded meanwhile, so a turn never stops at the window's edge.
      bool right = win.rightButtonDown();
      if (right && !looking && !io.WantCaptureMouse) looking = true;
      if (!right) looking = false;
      win.setCursorCaptured(looking);
      if (looking) in.look = win.mouseDelta();
      if (!io.WantCaptureMouse) in.scroll = win.scroll();
      in.seconds = std::min(seconds, 0.25f); // a stall does not fling the camera away
      update(fly, in);
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

    VkExtent2D extent = win.framebufferSize();
    if (extent.width == 0 || extent.height == 0) { // minimized: nothing to draw until restored
      ImGui::EndFrame();
      win.waitEvents();
      continue;
    }
    View v;
    v.camera = camera;
    v.config = ui.config;
    auto advanceReplay = [&] {
      if (replaying && ++replayIndex >= path.size()) {
        replaying = false;
        replayIndex = 0;
        writingPath = false;
        if (o.exitAfterPath) win.requestClose();
      }
    };
    auto overlayPanel = [&] {
      if (drawOverlayPanel(ui, stats)) {
        untried = true;
        presenter.swapchain->setPresentMode(vsyncMode(ui.vsync, *present));
      }
      ImGui::Render();
    };

    if (gpuPresent && !(replaying && writingPath) && !screenshot) {
      // Frames in flight: the scene records into the swapchain frame's command buffer, a blit takes
      // its colour target to the swapchain image, the overlay follows: one submit, no readback. The
      // stats shown are those of the frame this slot held before (framesInFlight - 1 frames late).
      auto sf = presenter.swapchain->beginFrame(extent);
      if (!sf) {
        ImGui::EndFrame();
        continue;
      }
      slotCompleted(presenter.blit, sf->slot);
      presenter.collect(sceneView, sf->slot, stats, gpuFrameMs);
      v.width = sf->extent.width;
      v.height = sf->extent.height;
      Status sceneRecorded = sceneView.record(sf->cmd, v, sf->slot);
      std::optional<Error> fatal;
      if (sceneRecorded) {
        presenter.pending[sf->slot] = true;
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
      presenter.finish(*sf);
      if (fatal) return *fatal;
      ++frames;
      if (o.maxFrames && frames >= o.maxFrames) win.requestClose();
      continue;
    }

    // Readback path: the scene renders and waits, the image goes through the CPU (PNG frames).
    presenter.drain(sceneView, stats, gpuFrameMs);
    // A recorded path renders at --size so its images match `mirage render --path` exactly.
    v.width = replaying && writingPath ? width : extent.width;
    v.height = replaying && writingPath ? height : extent.height;
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
    stats = frame->stats;
    for (const gpu::PassTime& t : stats.passTimes)
      if (t.name == "frame") gpuFrameMs.push_back(t.milliseconds);
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
    presenter.show(win, frame->srgb);
    ++frames;
    if (o.maxFrames && frames >= o.maxFrames) win.requestClose();
  }
  // How to measure the viewer (docs/viewer.md): frames per second of the whole loop (record or
  // render, blit or readback and upload, overlay, present) and the renderer's median GPU frame time.
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::sort(gpuFrameMs.begin(), gpuFrameMs.end());
  fmt::print("viewed {} frames in {:.2f} s: {:.1f} FPS, GPU frame median {:.3f} ms ({})\n", frames, seconds,
             seconds > 0.0 ? double(frames) / seconds : 0.0,
             gpuFrameMs.empty() ? 0.0 : gpuFrameMs[gpuFrameMs.size() / 2], (*context)->caps().name);
  return Ok{};
}

} // namespace mirage::viewer
