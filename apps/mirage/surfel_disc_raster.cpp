#include "surfel_disc_raster.h"

#include <algorithm>
#include <map>

#include <fmt/format.h>

namespace mirage::cli {

using surfels::DiscRaster;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

constexpr DiscRaster kAll[] = {DiscRaster::Compute, DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth};

} // namespace

double DiscRasterRun::stageMs(const std::string& name) const {
  for (const gpu::PassTime& t : times)
    if (t.name == name) return t.milliseconds;
  return 0.0;
}

Result<std::vector<DiscRaster>> parseDiscRasterList(const std::string& text) {
  if (text == "all") return std::vector<DiscRaster>(std::begin(kAll), std::end(kAll));
  std::vector<DiscRaster> list;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = std::min(text.find(',', start), text.size());
    auto r = surfels::parseDiscRaster(std::string_view(text).substr(start, end - start));
    if (!r) return Error{r.error().message + " (or all, or a comma list)"};
    if (std::find(list.begin(), list.end(), *r) == list.end()) list.push_back(*r);
    start = end + 1;
  }
  return list;
}

Result<std::vector<DiscRasterRun>> compareDiscRasters(gpu::Context& ctx, const surfels::GpuGBuffer& gb,
                                                      surfels::GpuSamplerConfig config,
                                                      const std::vector<DiscRaster>& rasters, int repeat) {
  std::vector<DiscRasterRun> runs(rasters.size());
  std::vector<std::map<std::string, std::vector<double>>> stageRuns(rasters.size());
  std::vector<std::vector<std::string>> stageOrder(rasters.size());
  std::vector<std::vector<double>> seconds(rasters.size());
  for (size_t i = 0; i < rasters.size(); ++i) {
    runs[i].raster = rasters[i];
    runs[i].skipped = surfels::discRasterUnsupported(ctx, rasters[i], gb.texels.viewCount);
  }
  // Round-robin over the splatters, so a change of load or clocks during the run hits all alike;
  // round -1 is an untimed warm-up of the first splatter.
  for (int k = -1; k < repeat; ++k)
    for (size_t i = 0; i < rasters.size(); ++i) {
      DiscRasterRun& run = runs[i];
      if (!run.skipped.empty() || (k < 0 && i > 0)) continue;
      config.discRaster = run.raster;
      auto r = surfels::sampleOnGpu(ctx, gb, config);
      if (!r) return r.error();
      if (k < 0) continue;
      for (const gpu::PassTime& t : r->times) {
        if (!stageRuns[i].count(t.name)) stageOrder[i].push_back(t.name);
        stageRuns[i][t.name].push_back(t.milliseconds);
      }
      seconds[i].push_back(r->seconds);
      run.rounds = r->rounds;
      if (k == 0) run.order = std::move(r->order);
    }
  const DiscRasterRun* first = nullptr;
  for (size_t i = 0; i < runs.size(); ++i) {
    DiscRasterRun& run = runs[i];
    if (!run.skipped.empty()) continue;
    for (const std::string& name : stageOrder[i]) run.times.push_back({name, median(stageRuns[i][name])});
    run.seconds = median(seconds[i]);
    if (!first) first = &run;
    run.sameOrderAsFirst = run.order.texels == first->order.texels && run.order.radii == first->order.radii;
  }
  return runs;
}

void printDiscRasterTable(const std::vector<DiscRasterRun>& runs) {
  const DiscRasterRun* base = nullptr;
  for (const DiscRasterRun& r : runs)
    if (r.skipped.empty() && r.raster == DiscRaster::Compute) base = &r;
  fmt::print("{:<10} {:>7} {:>12} {:>12} {:>12} {:>10} {:>10}  {}\n", "disc", "rounds", "voronoi ms", "conflicts ms",
             "all GPU ms", "voronoi", "conflicts", "order");
  for (const DiscRasterRun& r : runs) {
    if (!r.skipped.empty()) {
      fmt::print("{:<10} skipped: {}\n", surfels::toString(r.raster), r.skipped);
      continue;
    }
    double total = 0.0;
    for (const gpu::PassTime& t : r.times) total += t.milliseconds;
    auto ratio = [&](const char* stage) {
      if (!base || r.stageMs(stage) <= 0.0) return std::string("-");
      return fmt::format("{:.2f}x", r.stageMs(stage) / base->stageMs(stage));
    };
    fmt::print("{:<10} {:>7} {:>12.3f} {:>12.3f} {:>12.3f} {:>10} {:>10}  {}\n", surfels::toString(r.raster), r.rounds,
               r.stageMs("voronoi"), r.stageMs("conflicts"), total, ratio("voronoi"), ratio("conflicts"),
               r.sameOrderAsFirst ? "same" : "DIFFERS");
  }
  fmt::print("(ratios: time / compute's time per stage, > 1 = slower than compute; order: texels and radii vs the "
             "first splatter)\n");
}

nlohmann::json discRasterJson(const std::vector<DiscRasterRun>& runs) {
  nlohmann::json rows = nlohmann::json::array();
  for (const DiscRasterRun& r : runs) {
    nlohmann::json row = {{"disc_raster", surfels::toString(r.raster)}};
    if (!r.skipped.empty()) {
      row["skipped"] = r.skipped;
    } else {
      nlohmann::json stages = nlohmann::json::object();
      for (const gpu::PassTime& t : r.times) stages[t.name] = t.milliseconds;
      row["stages_ms"] = stages;
      row["rounds"] = r.rounds;
      row["sampler_seconds"] = r.seconds;
      row["same_order"] = r.sameOrderAsFirst;
    }
    rows.push_back(row);
  }
  return rows;
}

} // namespace mirage::cli
