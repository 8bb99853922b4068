#pragma once
// SVG plots of PVS size and pixel error against rays traced (`mirage pvs-eval --plot`): one
// hand-written SVG with two panels (log-scaled rays on x), one polyline per method.
#include <string>
#include <vector>

namespace mirage::vis {

struct PlotPoint {
  double rays = 0.0;
  double pvsTriangles = 0.0;
  double averageWrong = 0.0; // wrong pixels per view
};

struct PlotSeries {
  std::string name; // e.g. "GVS++", "RAND", "RASTER"
  std::vector<PlotPoint> points;
};

std::string pvsPlotSvg(const std::vector<PlotSeries>& series, const std::string& title);

} // namespace mirage::vis
