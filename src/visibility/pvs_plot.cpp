// SVG plots of PVS size and pixel error against rays (pvs_plot.h). Written by hand: the plot is a
// few polylines, axes and labels, not worth a dependency.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "mirage/visibility/pvs_plot.h"

namespace mirage::vis {

namespace {

constexpr double kPanelW = 420, kPanelH = 300, kMarginL = 70, kMarginT = 40, kMarginB = 50, kGap = 90;
constexpr const char* kColours[] = {"#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e"};

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

struct Range {
  double lo = 0, hi = 1;
};

// One panel: x = log10(rays), y = value (linear, from 0).
std::string panel(const std::vector<PlotSeries>& series, double x0, Range xr, Range yr, const char* yLabel,
                  double PlotPoint::*field) {
  std::string s;
  auto px = [&](double rays) {
    double lx = std::log10(std::max(rays, 1.0));
    return x0 + (lx - xr.lo) / std::max(xr.hi - xr.lo, 1e-9) * kPanelW;
  };
  auto py = [&](double v) { return kMarginT + kPanelH - (v - yr.lo) / std::max(yr.hi - yr.lo, 1e-12) * kPanelH; };
  s += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" "
                   "stroke=\"#444\"/>\n",
                   x0, kMarginT, kPanelW, kPanelH);
  for (int d = int(std::floor(xr.lo)); d <= int(std::ceil(xr.hi)); ++d) {
    double x = px(std::pow(10.0, d));
    if (x < x0 - 0.5 || x > x0 + kPanelW + 0.5) continue;
    s += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" stroke=\"#ddd\"/>\n", x,
                     kMarginT, kMarginT + kPanelH);
    s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"middle\">1e{}</text>\n", x,
                     kMarginT + kPanelH + 16, d);
  }
  for (int k = 0; k <= 4; ++k) {
    double v = yr.lo + (yr.hi - yr.lo) * k / 4.0;
    s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"end\">{:.4g}</text>\n", x0 - 6,
                     py(v) + 4, v);
  }
  s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" text-anchor=\"middle\">rays traced</text>\n",
                   x0 + kPanelW / 2, kMarginT + kPanelH + 36);
  s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" text-anchor=\"middle\">{}</text>\n",
                   x0 + kPanelW / 2, kMarginT - 8, yLabel);
  for (size_t i = 0; i < series.size(); ++i) {
    const char* colour = kColours[i % std::size(kColours)];
    std::string pts;
    for (const PlotPoint& p : series[i].points) pts += fmt::format("{:.1f},{:.1f} ", px(p.rays), py(p.*field));
    s += fmt::format("<polyline class=\"series\" data-name=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"2\" "
                     "points=\"{}\"/>\n",
                     escape(series[i].name), colour, pts);
    for (const PlotPoint& p : series[i].points)
      s += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3\" fill=\"{}\"/>\n", px(p.rays), py(p.*field), colour);
  }
  return s;
}

} // namespace

std::string pvsPlotSvg(const std::vector<PlotSeries>& series, const std::string& title) {
  Range xr{1e300, -1e300}, sizeR{0, 0}, errR{0, 0};
  for (const PlotSeries& s : series)
    for (const PlotPoint& p : s.points) {
      double lx = std::log10(std::max(p.rays, 1.0));
      xr.lo = std::min(xr.lo, lx);
      xr.hi = std::max(xr.hi, lx);
      sizeR.hi = std::max(sizeR.hi, p.pvsTriangles);
      errR.hi = std::max(errR.hi, p.averageWrong);
    }
  if (xr.lo > xr.hi) xr = {0, 1};
  xr.lo = std::floor(xr.lo * 4) / 4;
  xr.hi = std::max(xr.lo + 0.25, std::ceil(xr.hi * 4) / 4);
  sizeR.hi = sizeR.hi > 0 ? sizeR.hi * 1.05 : 1;
  errR.hi = errR.hi > 0 ? errR.hi * 1.05 : 1;
  const double width = kMarginL + 2 * kPanelW + kGap + 20, height = kMarginT + kPanelH + kMarginB + 20 * series.size();
  std::string s = fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0f}\" height=\"{:.0f}\" "
                              "viewBox=\"0 0 {:.0f} {:.0f}\" font-family=\"sans-serif\">\n",
                              width, height, width, height);
  s += fmt::format("<title>{}</title>\n", escape(title));
  s += fmt::format("<rect width=\"{:.0f}\" height=\"{:.0f}\" fill=\"white\"/>\n", width, height);
  s += panel(series, kMarginL, xr, sizeR, "PVS size (triangles)", &PlotPoint::pvsTriangles);
  s += panel(series, kMarginL + kPanelW + kGap, xr, errR, "average wrong pixels per view", &PlotPoint::averageWrong);
  for (size_t i = 0; i < series.size(); ++i) {
    double y = kMarginT + kPanelH + kMarginB + 14 + 20 * double(i);
    s += fmt::format("<line x1=\"{0:.0f}\" y1=\"{1:.0f}\" x2=\"{2:.0f}\" y2=\"{1:.0f}\" stroke=\"{3}\" "
                     "stroke-width=\"2\"/>\n<text x=\"{4:.0f}\" y=\"{5:.0f}\" font-size=\"12\">{6}</text>\n",
                     kMarginL, y, kMarginL + 24, kColours[i % std::size(kColours)], kMarginL + 30, y + 4,
                     escape(series[i].name));
  }
  s += "</svg>\n";
  return s;
}

} // namespace mirage::vis
