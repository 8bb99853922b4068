#include "render_options.h"

#include <string>

#include <CLI/CLI.hpp>

namespace mirage::cli {

namespace {

// A transformer binding an enum through its library parser: the name becomes the value's number
// (what CLI11 converts into the enum); a bad name fails the parse with the parser's message. In
// bench mode `sweepWord` (e.g. "all") sets *sweep and keeps the default.
template <typename E>
CLI::Validator enumNames(Result<E> (*parse)(std::string_view), E fallback, const char* sweepWord = nullptr,
                         bool* sweep = nullptr) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        if (sweep) *sweep = sweepWord && text == sweepWord;
        if (sweep && *sweep) {
          text = std::to_string(int(fallback));
          return "";
        }
        auto value = parse(text);
        if (!value) {
          // "--raster 'x': expected ..." -> "'x': expected ...": CLI11 puts the option name first.
          const std::string& m = value.error().message;
          size_t quote = m.find('\'');
          return quote == std::string::npos ? m : m.substr(quote);
        }
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
        return "'" + text + "': expected on, off" + (both ? " or both" : "");
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

CLI::Option* bindSceneOptions(CLI::App& cmd, runtime::SceneOptions& o, BindMode mode) {
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
      ->transform(enumNames(render::parseSurfelOrder, o.surfelOrder))
      ->default_str(render::toString(o.surfelOrder));
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
          ->transform(enumNames(render::parseRasterBackend, c.raster, "all", bench ? &sweeps->allRasters : nullptr))
          ->default_str(bench ? "all" : render::toString(c.raster)));
  lod.push_back(cmd.add_option("--hybrid-threshold", c.hybridThreshold,
                               ".mrg, hybrid raster: clusters whose estimated triangle edge reaches this many pixels "
                               "go to the hardware path")
                    ->capture_default_str());
  lod.push_back(
      cmd.add_option("--occlusion", c.occlusionCulling,
                     bench
                         ? ".mrg: two-pass HZB occlusion culling on|off|both (off: it cost more than it saved on "
                           "the H200)"
                         : ".mrg: two-pass HZB occlusion culling on|off (off: it cost more than it saved on the H200)")
          ->transform(onOff(bench ? &sweeps->bothOcclusion : nullptr))
          ->default_str(onOffName(c.occlusionCulling)));
  lod.push_back(cmd.add_option("--cones", c.coneCulling, ".mrg: normal-cone back-face culling on|off")
                    ->transform(onOff())
                    ->default_str(onOffName(c.coneCulling)));
  lod.push_back(cmd.add_option("--blend-raster", c.blendRaster,
                               bench ? ".mrg, alpha BLEND clusters: auto (hybrid), compute, hybrid, hardware, or all "
                                       "(each, timed as 'blend')"
                                     : ".mrg, alpha BLEND clusters: auto (hybrid), compute, hybrid or hardware")
                    ->transform(enumNames(render::parseBlendRaster, c.blendRaster, "all",
                                          bench ? &sweeps->allBlendRasters : nullptr))
                    ->default_str(render::toString(c.blendRaster)));
  lod.push_back(
      cmd.add_option("--selection", c.selection,
                     bench ? ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of "
                             "the kept levels), hierarchy (BVH over groups), dag (tree of the DAG's groups) or all"
                           : ".mrg: LOD cut selection: auto (hierarchy from 8192 instances), flat (every cluster of "
                             "the kept levels), hierarchy (BVH over groups) or dag (tree of the DAG's groups)")
          ->transform(
              enumNames(render::parseSelectionMode, c.selection, "all", bench ? &sweeps->allSelections : nullptr))
          ->default_str(render::toString(c.selection)));
  out.surfels.push_back(
      cmd.add_option("--surfel-size", c.surfelSize, "--surfels: surfel diameter in pixels")->capture_default_str());
  if (mode == BindMode::Render) // bench render draws surfels only in mixed scenes (bench surfels: the rest)
    out.surfels.push_back(cmd.add_option("--surfel-raster", c.surfelRaster, "--surfels: auto|compute|raster")
                              ->transform(enumNames(render::parseSurfelRaster, c.surfelRaster))
                              ->default_str(render::toString(c.surfelRaster)));
  return out;
}

} // namespace mirage::cli
