#include "render_options.h"

#include <cstddef>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

namespace mirage::cli {

namespace {

// A transformer binding an enum through its name table in the library: the name becomes the
// value's number (what CLI11 converts into the enum); a bad name fails the parse naming the choices.
// In bench mode `sweepWord` (e.g. "all") sets *sweep and keeps `fallback`, the default.
template <typename E, size_t N>
CLI::Validator enumNames(const EnumName<E> (&table)[N], E fallback, const char* sweepWord = nullptr,
                         bool* sweep = nullptr) {
  return CLI::Validator(
      [&table, fallback, sweepWord, sweep](std::string& text) -> std::string {
        if (sweep) *sweep = sweepWord && text == sweepWord;
        if (sweep && *sweep) {
          text = std::to_string(int(fallback));
          return "";
        }
        auto value = parseNamed(text, "", table);
        if (!value) // " 'x': expected a, b or c" (CLI11 puts the option's name first)
          return value.error().message.substr(1) + (sweep ? std::string(", or ") + sweepWord : "");
        text = std::to_string(int(*value));
        return "";
      },
      "");
}

// on|off into a bool (bench: `both` sets *both).
CLI::Validator onOff(bool* both = nullptr) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        if (both) *both = text == "both";
        if (text == "on" || text == "off" || (both && *both)) {
          text = text == "on" ? "true" : "false";
          return "";
        }
        return "'" + text + (both ? "': expected on, off or both" : "': expected on or off");
      },
      "");
}

const char* onOffName(bool value) { return value ? "on" : "off"; }

} // namespace

bool anyGiven(const std::vector<CLI::Option*>& options) {
  for (const CLI::Option* o : options)
    if (o->count() > 0) return true;
  return false;
}

void bindMaterials(CLI::App& cmd, std::string& materials) {
  cmd.add_option("--materials", materials,
                 "Material file (TOML): materials assigned to meshes or materials by name or glob, point lights "
                 "(docs/shading.md)")
      ->type_name("FILE.toml");
}

void bindGpuBudget(CLI::App& cmd, uint64_t& budget) {
  cmd.add_option("--gpu-budget", budget,
                 "Paged .mrg (mirage build --paged): GPU residency, page geometry within SIZE bytes (e.g. 64MB, "
                 "1GB; docs/render.md \"Residency\")")
      ->type_name("SIZE")
      ->transform(CLI::AsSizeValue(false));
}

void bindBandwidth(CLI::App& cmd, uint64_t& bitsPerSecond) {
  cmd.add_option("--bandwidth", bitsPerSecond,
                 ".mrg file or URL: receive at most RATE (e.g. 20Mbit, 500kbit, 1Gbit), a simulated link; with "
                 "--gpu-budget the pages stream in while frames run (docs/render.md \"Residency\")")
      ->type_name("RATE")
      ->transform(CLI::Validator(
          [](std::string& text) -> std::string {
            auto rate = asset::parseBandwidth(text);
            if (!rate) return rate.error().message;
            text = std::to_string(*rate);
            return "";
          },
          ""));
}

CLI::Option* bindSceneOptions(CLI::App& cmd, runtime::SceneOptions& o, BindMode mode) {
  bindMaterials(cmd, o.materials);
  bindGpuBudget(cmd, o.gpuBudget);
  cmd.add_option("--prefetch", o.prefetch,
                 "With --gpu-budget: a new view asks for the pages of every level of its cut at once, not one "
                 "level per frame round trip, on|off (docs/render.md \"Residency\"; same converged image)")
      ->transform(onOff(nullptr))
      ->type_name("on|off")
      ->default_str(onOffName(o.prefetch));
  cmd.add_option("--uploads", o.uploads,
                 "With --gpu-budget: page geometry to the GPU on the transfer queue (copy engines, beside the "
                 "frames; a later frame moves it into the pool), inside the frame that draws it first, or auto "
                 "(frame: the transfer queue measured no faster): auto|frame|transfer (docs/render.md "
                 "\"Residency\")")
      ->transform(enumNames(render::kUploadsNames, o.uploads))
      ->type_name("auto|frame|transfer")
      ->default_str("auto");
  bindBandwidth(cmd, o.source.bandwidthBitsPerSecond);
  if (mode == BindMode::Bench) {
    cmd.add_option("--pvs", o.pvs,
                   ".mrg: PVS from mirage pvs of the asset's source scene: every frame timed with and without the "
                   "camera cell's cluster PVS (no --camera/--path: 4 views from every cell's centre)");
    cmd.add_flag("--surfels", o.surfels, ".mrg with DAGs and per-mesh SURF chunks: meshes near, surfels far");
    cmd.add_option("--grid", o.grid, ".mrg: repeat the scene on an N x N grid (e.g. 50 -> 2500 instances)")
        ->capture_default_str();
    return nullptr;
  }
  cmd.add_option("--pvs", o.pvs,
                 "Draw only the PVS (from mirage pvs) of the view cell holding the camera (.mrg: its cluster PVS)");
  cmd.add_flag("--surfels", o.surfels, "Render the file's SURF chunk (.mrg from mirage surfels) or surfel .ply");
  return cmd
      .add_option("--surfel-order", o.surfelOrder,
                  "--surfels: splat order blue|coherent|coherent256 (default coherent256: Morton-sorted blocks, "
                  "docs/surfels.md)")
      ->type_name("NAME")
      ->transform(enumNames(render::kSurfelOrderNames, o.surfelOrder))
      ->default_str(render::toString(o.surfelOrder));
}

void bindStereo(CLI::App& cmd, StereoOptions& stereo) {
  CLI::Option* flag =
      cmd.add_flag("--stereo", stereo.enabled, "both eyes side by side (2W x H); .mrg: one shared LOD selection");
  cmd.add_option("--ipd", stereo.ipd, "--stereo: distance between the eyes, scene units")
      ->needs(flag)
      ->capture_default_str();
}

RenderConfigOptions bindRenderConfig(CLI::App& cmd, runtime::RenderConfig& c, BindMode mode, BenchSweeps* sweeps) {
  bool bench = mode == BindMode::Bench && sweeps;
  RenderConfigOptions out;
  auto& lod = out.clusterLod;
  lod.push_back(
      cmd.add_option("--tau", c.tauPixels, ".mrg: LOD threshold, projected error in pixels")->capture_default_str());
  lod.push_back(
      cmd.add_option("--raster", c.raster,
                     bench ? ".mrg: all|auto|mesh|indirect|compute|hybrid" : ".mrg: auto|mesh|indirect|compute|hybrid")
          ->type_name("NAME")
          ->transform(enumNames(render::kRasterBackendNames, c.raster, "all", bench ? &sweeps->allRasters : nullptr))
          ->default_str(bench ? "all" : render::toString(c.raster)));
  lod.push_back(cmd.add_option("--hybrid-threshold", c.hybridThreshold,
                               ".mrg, hybrid raster: clusters whose estimated triangle edge reaches this many pixels "
                               "go to the hardware path")
                    ->capture_default_str());
  lod.push_back(cmd.add_option("--lean-raster", c.leanRaster,
                               bench ? ".mrg, compute raster: small clusters by the lean kernel on|off|both "
                                       "(docs/render.md, \"Lean raster\"; same image)"
                                     : ".mrg, compute raster: small clusters by the lean kernel on|off "
                                       "(docs/render.md, \"Lean raster\"; same image)")
                    ->transform(onOff(bench ? &sweeps->bothLean : nullptr))
                    ->type_name(bench ? "on|off|both" : "on|off")
                    ->default_str(onOffName(c.leanRaster)));
  lod.push_back(cmd.add_option("--blend-queue-pixels", c.blendQueuePixels,
                               ".mrg, compute blend raster: blended triangles whose pixel box exceeds this many pixels "
                               "are spread over the GPU by the blend queue (inf: off)")
                    ->capture_default_str());
  lod.push_back(
      cmd.add_option("--occlusion", c.occlusionCulling,
                     bench
                         ? ".mrg: two-pass HZB occlusion culling on|off|both (off: it cost more than it saved on "
                           "the H200)"
                         : ".mrg: two-pass HZB occlusion culling on|off (off: it cost more than it saved on the H200)")
          ->transform(onOff(bench ? &sweeps->bothOcclusion : nullptr))
          ->type_name(bench ? "on|off|both" : "on|off")
          ->default_str(onOffName(c.occlusionCulling)));
  lod.push_back(cmd.add_option("--cones", c.coneCulling, ".mrg: normal-cone back-face culling on|off")
                    ->transform(onOff())
                    ->type_name("on|off")
                    ->default_str(onOffName(c.coneCulling)));
  lod.push_back(cmd.add_option("--blend-raster", c.blendRaster,
                               bench ? ".mrg, alpha BLEND clusters: auto (compute with the blend queue), compute, "
                                       "hybrid, hardware, or all (each, timed as 'blend')"
                                     : ".mrg, alpha BLEND clusters: auto (compute with the blend queue), compute, "
                                       "hybrid or hardware")
                    ->type_name("NAME")
                    ->transform(enumNames(render::kBlendRasterNames, c.blendRaster, "all",
                                          bench ? &sweeps->allBlendRasters : nullptr))
                    ->default_str(render::toString(c.blendRaster)));
  lod.push_back(
      cmd.add_option("--selection", c.selection,
                     bench ? ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of "
                             "the kept levels), hierarchy (BVH over groups), dag (tree of the DAG's groups) or all"
                           : ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of "
                             "the kept levels), hierarchy (BVH over groups) or dag (tree of the DAG's groups)")
          ->type_name("NAME")
          ->transform(
              enumNames(render::kSelectionModeNames, c.selection, "all", bench ? &sweeps->allSelections : nullptr))
          ->default_str(render::toString(c.selection)));
  lod.push_back(
      cmd.add_option(
             "--stereo-mode", c.stereoMode,
             ".mrg, --stereo: how the mesh, indirect and hybrid rasters draw both eyes: auto "
             "(per-eye viewports: measured faster on the H100), multiview (VK_KHR_multiview) or viewports (each "
             "eye with its viewport)")
          ->type_name("NAME")
          ->transform(enumNames(render::kStereoModeNames, c.stereoMode))
          ->default_str(render::toString(c.stereoMode)));
  lod.push_back(cmd.add_option("--debug-view", c.debugView,
                               ".mrg: none|clusters|lod|density|overdraw: colour by cluster, DAG level, triangles per "
                               "pixel or overdraw instead of shading (docs/render.md, \"Debug views\")")
                    ->type_name("NAME")
                    ->transform(enumNames(render::kDebugViewNames, c.debugView))
                    ->default_str(render::toString(c.debugView)));
  // Foveation: the gaze point sets foveation on; ranges are checked by runtime::validate.
  auto* fovea = cmd.add_option_function<std::string>(
                       "--fovea",
                       [&c](const std::string& text) {
                         std::sscanf(text.c_str(), "%f,%f", &c.foveaGaze.x, &c.foveaGaze.y);
                         c.foveation = true;
                       },
                       ".mrg: foveation: gaze point X,Y in normalized screen coordinates (0,0 top left); tau grows "
                       "with eccentricity beyond --fovea-radius (docs/runtime.md)")
                    ->type_name("X,Y")
                    ->check(CLI::Validator(
                        [](std::string& text) -> std::string {
                          float x = 0, y = 0;
                          char extra = 0;
                          if (std::sscanf(text.c_str(), "%f,%f%c", &x, &y, &extra) != 2)
                            return "'" + text + "': expected X,Y";
                          return "";
                        },
                        ""));
  lod.push_back(fovea);
  lod.push_back(cmd.add_option("--fovea-radius", c.foveaRadiusDegrees, ".mrg, --fovea: fovea radius in degrees")
                    ->needs(fovea)
                    ->capture_default_str());
  // Not in clusterLod: forward scenes take it too (cluster LOD ones take linked-list, packed and fixed).
  cmd.add_option("--oit", c.oit,
                 "alpha BLEND: auto (fixed for .mrg cluster LOD, linked-list forward), linked-list (per-pixel "
                 "sorted lists), packed (per-pixel contiguous ranges, two rasterizations; cluster LOD only), "
                 "fixed (packed storage in fixed slots per pixel, one rasterization unless a pixel outnumbers "
                 "its slots; the same image as packed; cluster LOD only), weighted (weighted blended, "
                 "approximate; forward only) or sorted (every blended triangle back to front, the reference; "
                 "forward only)")
      ->type_name("NAME")
      ->transform(enumNames(render::kOitModeNames, c.oit))
      ->default_str(render::toString(c.oit));
  cmd.add_option("--oit-nodes-per-pixel", c.oitNodesPerPixel,
                 "alpha BLEND, linked lists: fragment pool per target pixel (default 4 for .mrg cluster LOD, 8 "
                 "forward); past it a fragment replaces its pixel's farthest listed one (packed, fixed: the "
                 "nearest are kept; fixed: the slots per pixel, at most 16)")
      ->type_name("N");
  out.surfels.push_back(
      cmd.add_option("--surfel-size", c.surfelSize, "--surfels: surfel diameter in pixels")->capture_default_str());
  if (mode == BindMode::Render) // bench render draws surfels only in mixed scenes (bench surfels: the rest)
    out.surfels.push_back(cmd.add_option("--surfel-raster", c.surfelRaster, "--surfels: auto|compute|raster")
                              ->type_name("NAME")
                              ->transform(enumNames(render::kSurfelRasterNames, c.surfelRaster))
                              ->default_str(render::toString(c.surfelRaster)));
  return out;
}

CLI::Option* bindFrameTimeTarget(CLI::App& cmd, runtime::FrameTimeSettings& s) {
  return cmd.add_option("--target-ms", s.targetMs,
                        fmt::format(".mrg: hold this GPU frame time, choosing each frame's tau in {}..{} px (and the "
                                    "surfel size) from the last frames' times",
                                    s.tauMin, s.tauMax));
}

} // namespace mirage::cli
