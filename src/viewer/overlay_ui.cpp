#include "overlay_ui.h"

#include <iterator>

#include <imgui.h>

#include "keys.h"

namespace mirage::viewer {

namespace {

const char* kRasterNames[] = {"auto", "mesh", "indirect", "compute", "hybrid"};
const render::RasterBackend kRasters[] = {render::RasterBackend::Auto, render::RasterBackend::Mesh,
                                          render::RasterBackend::Indirect, render::RasterBackend::Compute,
                                          render::RasterBackend::Hybrid};

} // namespace

bool drawOverlayPanel(UiState& s, const FrameStats& stats) {
  bool changed = false;
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowBgAlpha(0.75f);
  ImGui::Begin("mirage", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::Text("%.1f FPS  %.2f ms/frame", s.cpuFrameMs > 0.0 ? 1000.0 / s.cpuFrameMs : 0.0, s.cpuFrameMs);
  ImGui::Text("latency %.1f ms: input->submit %.1f, submit->GPU done %.1f", s.inputToPresentMs, s.inputToSubmitMs,
              s.submitToGpuMs);
  if (s.stereoIpd > 0.0f) ImGui::Text("stereo, ipd %.3f: left | right", s.stereoIpd);
  if (ImGui::CollapsingHeader("GPU passes", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (const gpu::PassTime& t : stats.passTimes) ImGui::Text("%-10s %8.3f ms", t.name.c_str(), t.milliseconds);
    if (stats.passTimes.empty()) ImGui::TextUnformatted("(no timestamp queries)");
  }
  ImGui::Text("triangles %llu", static_cast<unsigned long long>(stats.triangles));
  if (s.clusterLod) ImGui::Text("clusters  %llu", static_cast<unsigned long long>(stats.clusters));
  if (s.hasSurfels) ImGui::Text("surfels   %llu", static_cast<unsigned long long>(stats.surfels));
  if (stats.cell >= 0)
    ImGui::Text("view cell %d", stats.cell);
  else if (stats.cell == -1)
    ImGui::TextUnformatted("view cell: none (no PVS culling)");

  ImGui::Separator();
  if (s.clusterLod) {
    if (s.targetMs > 0.0) {
      changed |= ImGui::Checkbox("hold target", &s.holdTarget);
      ImGui::SameLine();
      ImGui::Text("%.1f ms: tau %.2f px", s.targetMs, s.config.tauPixels);
    }
    ImGui::BeginDisabled(s.holdTarget); // the controller sets tau each frame
    changed |= ImGui::SliderFloat("tau (px)", &s.config.tauPixels, 0.25f, 16.0f, "%.2f", ImGuiSliderFlags_Logarithmic);
    ImGui::EndDisabled();
    int raster = 0;
    for (int i = 0; i < 5; ++i)
      if (kRasters[i] == s.config.raster) raster = i;
    if (ImGui::Combo("raster", &raster, kRasterNames, 5)) {
      s.config.raster = kRasters[raster];
      changed = true;
    }
    // Debug views (docs/render.md): the table's order is the enum's.
    auto debugName = [](void*, int i, const char** out) {
      *out = render::kDebugViewNames[i].name;
      return true;
    };
    int debug = int(s.config.debugView);
    if (ImGui::Combo("debug view", &debug, debugName, nullptr, int(std::size(render::kDebugViewNames)))) {
      s.config.debugView = render::DebugView(debug);
      changed = true;
    }
    changed |= ImGui::Checkbox("occlusion culling", &s.config.occlusionCulling);
    changed |= ImGui::Checkbox("normal-cone culling", &s.config.coneCulling);
    if (s.hasPvs) changed |= ImGui::Checkbox("PVS culling", &s.config.pvsCulling);
    if (s.hasBlend) changed |= ImGui::Checkbox("transparency (T)", &s.config.transparency);
    if (s.mixed) changed |= ImGui::Checkbox("surfels (U)", &s.config.drawSurfels);
    if (s.config.foveation) {
      changed |= ImGui::SliderFloat2("fovea x,y", &s.config.foveaGaze.x, 0.0f, 1.0f, "%.2f");
      changed |= ImGui::SliderFloat("fovea radius (deg)", &s.config.foveaRadiusDegrees, 0.5f, 60.0f, "%.1f");
    }
  }
  if (s.hasSurfels) {
    ImGui::BeginDisabled(s.holdTarget);
    changed |= ImGui::SliderFloat("surfel size (px)", &s.config.surfelSize, 0.5f, 16.0f, "%.2f");
    ImGui::EndDisabled();
  }
  changed |= ImGui::Checkbox("vsync (V)", &s.vsync);

  ImGui::Separator();
  ImGui::TextUnformatted("WASD/QE move, right button look, wheel speed");
  if (ImGui::CollapsingHeader("keys"))
    for (const KeyBinding& b : keyBindings()) ImGui::Text("%-4s %s", b.name, b.what);
  if (!s.camera.empty()) ImGui::TextWrapped("--camera %s (copied)", s.camera.c_str());
  if (s.recording) ImGui::Text("recording: %zu cameras", s.recorded);
  if (s.replaying) ImGui::TextUnformatted("replaying path");
  if (!s.message.empty()) ImGui::TextWrapped("%s", s.message.c_str());
  ImGui::End();
  return changed;
}

} // namespace mirage::viewer
