// The pvs-eval SVG plot: well-formed (every tag closed, properly nested), one polyline per series,
// and through the CLI, checkpoints that grow in rays for every method.
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mirage/visibility/pvs_plot.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace mirage::vis;

namespace {

// A small XML check: tags nest and close, attributes are quoted; returns the first problem or "".
std::string xmlProblem(const std::string& s) {
  std::vector<std::string> open;
  size_t i = 0;
  while ((i = s.find('<', i)) != std::string::npos) {
    size_t end = s.find('>', i);
    if (end == std::string::npos) return "unterminated tag";
    std::string tag = s.substr(i + 1, end - i - 1);
    if (std::count(tag.begin(), tag.end(), '"') % 2) return "unbalanced quotes in <" + tag + ">";
    if (tag.find('<') != std::string::npos) return "'<' inside a tag";
    if (!tag.empty() && tag[0] == '/') {
      if (open.empty() || open.back() != tag.substr(1)) return "unexpected </" + tag.substr(1) + ">";
      open.pop_back();
    } else if (tag.empty() || tag.back() != '/') {
      open.push_back(tag.substr(0, tag.find(' ')));
    }
    i = end + 1;
  }
  return open.empty() ? "" : "unclosed <" + open.back() + ">";
}

} // namespace

TEST(PvsPlot, SvgIsWellFormedWithOneLinePerSeries) {
  std::vector<PlotSeries> series{{"GVS++", {{1e4, 100, 5.0}, {1e5, 900, 0.5}, {2e6, 1000, 0.0}}},
                                 {"RAND", {{1e4, 80, 20.0}, {1e5, 600, 9.0}, {2e6, 800, 3.0}}},
                                 {"R<A&S>", {{3e4, 10, 1.0}}}};
  std::string svg = pvsPlotSvg(series, "a & b");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(xmlProblem(svg), "");
  EXPECT_NE(svg.find("data-name=\"GVS++\""), std::string::npos);
  EXPECT_NE(svg.find("data-name=\"RAND\""), std::string::npos);
  EXPECT_NE(svg.find("data-name=\"R&lt;A&amp;S&gt;\""), std::string::npos);
  size_t lines = 0;
  for (size_t at = 0; (at = svg.find("<polyline", at)) != std::string::npos; ++at) ++lines;
  EXPECT_EQ(lines, 2 * series.size()); // one per panel
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(xmlProblem(pvsPlotSvg({}, "empty")), "");
}

TEST(PvsPlot, EvalWritesCheckpointsMonotoneInRays) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_plot");
  std::ofstream(dir / "c.json") << R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]}]})";
  fs::path svgPath = dir / "plot.svg", jsonPath = dir / "out.json";
  std::string cmd = mirage::test::mirageBinary() + " pvs-eval gen:city:1 --cells " + (dir / "c.json").string() +
                    " --rays 4000 --abs-edge 4 --size 16 --viewpoints 1 --raster-size 16 --backend embree --plot " +
                    svgPath.string() + " --json > " + jsonPath.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(svgPath);
  std::string svg((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(xmlProblem(svg), "");
  for (const char* name : {"GVS++", "RAND", "RASTER"})
    EXPECT_NE(svg.find(std::string("data-name=\"") + name + "\""), std::string::npos) << name;
  nlohmann::json j = nlohmann::json::parse(std::ifstream(jsonPath));
  std::map<std::string, std::vector<double>> rays;
  for (const auto& p : j["plot"]) rays[p["method"].get<std::string>()].push_back(p["rays"].get<double>());
  ASSERT_EQ(rays.size(), 3u);
  for (const auto& [method, r] : rays) {
    EXPECT_GE(r.size(), 2u) << method;
    for (size_t i = 1; i < r.size(); ++i) EXPECT_GT(r[i], r[i - 1]) << method;
  }
  EXPECT_TRUE(j.contains("raster_average_wrong"));
  EXPECT_GT(j["cells"][0]["raster"]["triangles"].get<size_t>(), 0u);
}
