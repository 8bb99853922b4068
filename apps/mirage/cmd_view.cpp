// mirage view SCENE: the interactive viewer (src/viewer; docs/viewer.md). Only binds flags.
#include <memory>

#include <CLI/CLI.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/viewer/viewer.h"
#include "render_options.h"

namespace mirage::cli {

namespace {

struct ViewFlags {
  viewer::ViewerOptions options;
  RenderConfigOptions given;
  StereoOptions stereo;
  runtime::FrameTimeSettings frameTime;
  CLI::Option* targetMs = nullptr;
};

} // namespace

void addViewCommand(CLI::App& app) {
  auto f = std::make_shared<ViewFlags>();
  viewer::ViewerOptions& o = f->options;
  auto* cmd = app.add_subcommand("view", "Look at a scene in a window: fly camera, overlay, camera paths");
  cmd->add_option("scene", o.scene, "Baked .mrg (cluster LOD) or a scene file (.gltf .glb .obj .ply)")->required();
  cmd->add_option("--camera", o.camera, "Start camera eye=x,y,z,target=x,y,z[,fov=60][,up=x,y,z]; default: 3/4 view");
  cmd->add_option("--size", o.size, "Window size WxH (with --stereo: of one eye, the window is 2W x H)")
      ->capture_default_str();
  cmd->add_option("--present", o.present, "fifo|mailbox|immediate (unavailable modes fall back to fifo)")
      ->capture_default_str();
  cmd->add_option("--device", o.device, "Vulkan device name substring or index (or MIRAGE_DEVICE)");
  cmd->add_option("--pvs", o.pvs, ".mrg: cull with the PVS (from mirage pvs) of the camera's view cell");
  cmd->add_flag("--surfels", o.surfels, ".mrg: draw its per-mesh SURF chunks far away (mixed scene)");
  bindMaterials(*cmd, o.materials);
  bindGpuBudget(*cmd, o.gpuBudget);
  bindBandwidth(*cmd, o.bandwidth);
  cmd->add_option("--path", o.path, "Camera path (cameras.json or orbit:N), replayed one camera per frame");
  cmd->add_option("--screenshot", o.screenshot, "With --path: write OUT_0000.png ... as mirage render --path does");
  cmd->add_flag("--exit-after-path", o.exitAfterPath, "Close once the path was shown (tests, measurements)");
  cmd->add_option("--frames", o.maxFrames, "Close after N frames (0: run until closed)");
  cmd->add_option("--keys", o.keys, "Press action keys at frames, KEY@FRAME,... (e.g. C@1,F12@2; scripted runs)");
  f->given = bindRenderConfig(*cmd, o.config, BindMode::Render);
  bindStereo(*cmd, f->stereo);
  f->targetMs = bindFrameTimeTarget(*cmd, f->frameTime);
  cmd->callback([f] {
    viewer::ViewerOptions& vo = f->options;
    vo.clusterLodFlags = anyGiven(f->given.clusterLod);
    vo.surfelFlags = anyGiven(f->given.surfels);
    vo.stereoIpd = f->stereo.ipdOrNone();
    if (f->targetMs->count() > 0) vo.frameTime = f->frameTime;
    if (auto st = viewer::runViewer(vo); !st) fail(st.error());
  });
}

} // namespace mirage::cli
