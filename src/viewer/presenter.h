#pragma once
// What every window loop of src/viewer shares (the scene viewer and the stream client window):
// Dear ImGui's context on the window, and the presenter that takes a frame to the swapchain (GPU
// blit of a renderer's colour target or a CPU image through staging), times it and presents it.
#include <chrono>
#include <memory>
#include <optional>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <imgui.h>

#include "mirage/gpu/swapchain.h"
#include "frame_log.h"
#include "overlay_renderer.h"
#include "present.h"
#include "scene_view.h"
#include "window.h"

namespace mirage::viewer {

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

using Clock = std::chrono::steady_clock;

// The renderer's "frame" pass of a frame's stats; negative without timestamp queries.
inline double gpuFrameMs(const FrameStats& stats) { return gpu::passMilliseconds(stats.passTimes, "frame", -1.0); }

// Everything the loop owns on the GPU side, destroyed after the device went idle.
struct Presenter {
  gpu::Context& context;
  std::unique_ptr<gpu::Swapchain> swapchain;
  std::unique_ptr<OverlayRenderer> overlay;
  PresentStaging staging;
  TargetBlit blit;
  Clock::time_point epoch = Clock::now();
  FrameLog log;
  // Swapchain slots whose scene frame was recorded and not yet collected (the scene's slots are the
  // swapchain's: both counts are 3 at most), with the tau each was drawn with (frame-time control).
  bool pending[gpu::kMaxFramesInFlight] = {};
  float pendingTau[gpu::kMaxFramesInFlight] = {};
  SubmitStamp stamps[gpu::kMaxFramesInFlight]; // latency: submits waiting for their fence
  static_assert(gpu::kMaxFramesInFlight <= render::kMaxFramesInFlight);
  ~Presenter() {
    if (swapchain) swapchain->waitIdle();
  }
  double now() const { return std::chrono::duration<double>(Clock::now() - epoch).count(); }
  // Submits whose fence signalled since: their submit -> GPU done time.
  void pollCompleted() {
    for (uint32_t i = 0; i < swapchain->framesInFlight(); ++i)
      if (stamps[i].pending && swapchain->completed(i)) {
        log.submitToGpuMs.push_back((now() - stamps[i].submitSeconds) * 1000.0);
        stamps[i].pending = false;
      }
  }
  std::optional<gpu::Swapchain::Frame> begin(VkExtent2D extent) {
    auto frame = swapchain->beginFrame(extent);
    pollCompleted(); // beginFrame waited for the slot's fence
    return frame;
  }
  // Readback path: shows `image` with the overlay (ImGui::Render done) when the swapchain gives an image.
  void show(const Window& window, const ImageRGBA8& image, double inputSeconds) {
    auto frame = begin(window.framebufferSize());
    if (!frame) return;
    slotCompleted(blit, frame->slot);
    cmdCopyFrameToSwapchain(context, staging, *frame, swapchain->format(), image);
    finish(*frame, inputSeconds);
  }
  // The overlay (ImGui::Render done), then submit and present, timed from the input poll.
  void finish(const gpu::Swapchain::Frame& frame, double inputSeconds) {
    overlay->record(frame.cmd, frame.slot, frame.view, frame.extent, ImGui::GetDrawData());
    cmdTransitionForPresent(frame.cmd, frame.image);
    swapchain->submit(frame);
    double submitted = now();
    stamps[frame.slot] = {true, submitted};
    log.inputToSubmitMs.push_back((submitted - inputSeconds) * 1000.0);
    swapchain->present(frame);
    log.inputToPresentMs.push_back((now() - inputSeconds) * 1000.0);
    pollCompleted();
  }
  // The stats of slot `slot`'s recorded frame, if it holds one (its fence signalled).
  std::optional<FrameStats> collect(SceneView& scene, uint32_t slot) {
    if (!pending[slot]) return std::nullopt;
    pending[slot] = false;
    auto collected = scene.collect(slot);
    if (!collected) return std::nullopt;
    if (double ms = gpuFrameMs(*collected); ms >= 0.0) log.gpuFrameMs.push_back(ms);
    return std::move(*collected);
  }
  // Before a frame through Scene::render (it uses slot 0 and waits): the frames in flight finish.
  // Rare: frames written to PNG, scenes switching paths never.
  template <typename OnStats> void drain(SceneView& scene, OnStats onStats) {
    bool any = false;
    for (bool p : pending) any = any || p;
    if (!any) return;
    swapchain->waitIdle();
    pollCompleted();
    for (uint32_t i = 0; i < gpu::kMaxFramesInFlight; ++i)
      if (auto stats = collect(scene, i)) onStats(*stats, pendingTau[i]);
  }
};

} // namespace mirage::viewer
