// mirage demo: the main job on an embedded default. Generates procedural scenes (no downloaded
// asset), writes them as GLB, renders a few views to PNG and says where everything is. It grows
// as subsystems land (LOD bake, surfels, PVS).
#include <chrono>
#include <filesystem>

#include <fmt/format.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/io/generate.h"
#include "mirage/io/gltf_write.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct DemoOptions {
  std::string out = "demo-out";
  std::string size = "1280x720";
  std::string device;
  uint32_t seed = 1;
};

struct DemoScene {
  const char* kind;
  uint64_t sizeParameter; // blocks / grid resolution / subdivisions: small enough for lavapipe
};

double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

void runDemo(const DemoOptions& o) {
  uint32_t width = 0, height = 0;
  if (auto s = parseSize(o.size, width, height); !s) return fail(s.error());
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec || !std::filesystem::is_directory(o.out)) return fail(makeError(o.out, "cannot create the output folder"));

  gpu::ContextOptions co;
  co.device = o.device;
  auto ctx = gpu::Context::create(co);
  if (!ctx) return fail(ctx.error());
  fmt::print("mirage demo on {} ({}x{}), output in {}/\n", (*ctx)->caps().name, width, height, o.out);

  const DemoScene scenes[] = {{"city", 0}, {"terrain", 0}, {"blob", 0}};
  for (const DemoScene& d : scenes) {
    auto t0 = std::chrono::steady_clock::now();
    auto scene = io::generateScene(d.kind, o.seed, d.sizeParameter);
    if (!scene) return fail(scene.error());
    double genSeconds = secondsSince(t0);
    std::filesystem::path glb = std::filesystem::path(o.out) / fmt::format("{}.glb", d.kind);
    if (auto s = io::writeGlb(*scene, glb); !s) return fail(s.error());
    fmt::print("  {:<8} {:>10} triangles, {:>5} instances, generated in {:.2f} s -> {}\n", d.kind,
               scene->instancedTriangleCount(), scene->instances.size(), genSeconds, glb.string());

    auto renderer = render::ForwardRenderer::create(**ctx, *scene);
    if (!renderer) return fail(renderer.error());
    Bounds b = scene->worldBounds();
    float aspect = float(width) / float(height);
    render::Camera overview = render::autoCamera(b, aspect);
    // A second, closer and lower view from the other side.
    render::Camera close = overview;
    glm::vec3 c = b.center();
    float r = b.radius();
    close.eye = c + glm::vec3(-0.55f * r, 0.28f * r, -0.65f * r);
    close.target = c - glm::vec3(0.0f, 0.15f * r, 0.0f);
    close.znear = close.zfar = 0.0f;
    const std::pair<const char*, render::Camera> views[] = {{"overview", overview}, {"close", close}};
    for (const auto& [name, cam] : views) {
      render::RenderSettings rs;
      rs.width = width;
      rs.height = height;
      rs.camera = cam;
      auto out = (*renderer)->render(rs);
      if (!out) return fail(out.error());
      std::filesystem::path png = std::filesystem::path(o.out) / fmt::format("{}-{}.png", d.kind, name);
      if (auto s = io::writePng(png, out->srgb); !s) return fail(s.error());
      double gpuMs = out->stats.passTimes.empty() ? 0.0 : out->stats.passTimes[0].milliseconds;
      fmt::print("           rendered {:<8} in {:8.2f} ms GPU -> {}\n", name, gpuMs, png.string());
    }
  }
  fmt::print("done: open the PNGs in {}/, or render a GLB yourself: mirage render {}/city.glb -o city.png --stats\n",
             o.out, o.out);
}

} // namespace

void addDemoCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "Generate procedural scenes, render them, and say where the images are");
  auto o = std::make_shared<DemoOptions>();
  cmd->add_option("--out", o->out, "Output folder (created if missing)")->capture_default_str();
  cmd->add_option("--size", o->size, "WxH of the rendered views")->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the generated scenes")->capture_default_str();
  cmd->add_option("--device", o->device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->callback([o] { runDemo(*o); });
}

} // namespace mirage::cli
