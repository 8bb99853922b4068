// View cells: JSON parsing and its errors, degenerate cells, grids, face sampling geometry.
#include <random>

#include <gtest/gtest.h>

#include "mirage/visibility/gvs.h"
#include "mirage/visibility/view_cell.h"

using namespace mirage;
using namespace mirage::vis;

namespace {

std::string parseError(const std::string& json) {
  auto r = parseViewCells(json, "cells.json");
  return r.ok() ? std::string("(ok)") : r.error().message;
}

} // namespace

TEST(ViewCells, ParsesBoxesAndRects) {
  auto r = parseViewCells(R"({"cells": [
      {"type": "box", "position": [1, 2, 3], "size": [2, 3, 4], "rotation": [0, 90, 0]},
      {"type": "rect", "position": [0, 1.7, 0], "size": [5, 6]}]})",
                          "cells.json");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].shape, CellShape::Box);
  EXPECT_EQ((*r)[0].size, glm::vec3(2, 3, 4));
  EXPECT_EQ((*r)[1].shape, CellShape::Rect);
  EXPECT_EQ((*r)[1].size, glm::vec3(5, 0, 6));
  // Round trip through the writer.
  auto again = parseViewCells(viewCellsToJson(*r), "again.json");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ((*again)[0].rotation, (*r)[0].rotation);
}

TEST(ViewCells, RejectsBadInputWithOneLineErrors) {
  EXPECT_EQ(parseError("{"), "cells.json: not valid JSON");
  EXPECT_EQ(parseError("{}"), "cells.json: expected a \"cells\" array");
  EXPECT_EQ(parseError("[]"), "cells.json: no view cells");
  EXPECT_EQ(parseError(R"([{"size": [1,1,1]}])"), "cells.json: cell 0: missing \"position\"");
  EXPECT_EQ(parseError(R"([{"position": [0,0], "size": [1,1,1]}])"),
            "cells.json: cell 0: \"position\" must be an array of 3 numbers");
  EXPECT_EQ(parseError(R"([{"type": "sphere", "position": [0,0,0], "size": [1,1,1]}])"),
            "cells.json: cell 0: unknown type \"sphere\" (expected \"box\" or \"rect\")");
  EXPECT_EQ(parseError(R"([{"position": [0,0,0], "size": [1,1,1], "colour": 1}])"),
            "cells.json: cell 0: unknown key \"colour\"");
  EXPECT_EQ(parseError(R"([{"position": [0,0,0], "size": [1,"a",1]}])"),
            "cells.json: cell 0: \"size\" must hold numbers");
  for (const std::string& e :
       {parseError(R"([{"position": [0,0,0], "size": [1,1,1]}, {"position": [0,0,0], "size": [1,0,1]}])"),
        parseError(R"([{"position": [0,0,0], "size": [1,1e-9,1]}])"),
        parseError(R"([{"type": "rect", "position": [0,0,0], "size": [0,1]}])"),
        parseError(R"([{"position": [0,0,0], "size": [1,-1,1]}])")}) {
    EXPECT_NE(e.find("degenerate"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
  EXPECT_NE(
      parseError(R"([{"position": [0,0,0], "size": [1,1,1]}, {"position": [0,0,0], "size": [1,0,1]}])").find("cell 1"),
      std::string::npos);
}

TEST(ViewCells, FacesCoverTheSurfaceWithOutwardNormals) {
  ViewCell c;
  c.position = {1, 2, 3};
  c.size = {2, 4, 6};
  c.rotation = {10, 20, 30};
  auto faces = cellFaces(c);
  ASSERT_EQ(faces.size(), 6u);
  float area = 0;
  for (const CellFace& f : faces) {
    area += f.area;
    glm::vec3 centre = f.corner + 0.5f * (f.edgeU + f.edgeV);
    // Outward: the face centre lies away from the cell centre along the normal.
    EXPECT_GT(glm::dot(centre - c.position, f.normal), 0.0f);
    EXPECT_NEAR(glm::length(glm::cross(f.edgeU, f.edgeV)), f.area, 1e-3f);
    EXPECT_TRUE(c.contains(centre));
  }
  EXPECT_NEAR(area, c.surfaceArea(), 1e-3f);
  EXPECT_EQ(c.corners().size(), 8u);
  EXPECT_EQ(c.edges().size(), 12u);
  ViewCell r;
  r.shape = CellShape::Rect;
  r.size = {3, 0, 2};
  EXPECT_EQ(cellFaces(r).size(), 1u);
  EXPECT_EQ(r.corners().size(), 4u);
  EXPECT_EQ(r.edges().size(), 4u);
}

TEST(ViewCells, GridTilesTheRegion) {
  Bounds b;
  b.add({0, 0, 0});
  b.add({10, 3, 20});
  auto cells = gridCells(b, {2, 1, 4});
  ASSERT_TRUE(cells.ok());
  ASSERT_EQ(cells->size(), 8u);
  EXPECT_EQ((*cells)[0].size, glm::vec3(5, 3, 5));
  EXPECT_EQ((*cells)[0].position, glm::vec3(2.5f, 1.5f, 2.5f));
  Bounds flat;
  flat.add({0, 1.7f, 0});
  flat.add({10, 1.7f, 10});
  auto rects = gridCells(flat, {2, 1, 2});
  ASSERT_TRUE(rects.ok());
  EXPECT_EQ((*rects)[0].shape, CellShape::Rect);
  EXPECT_FALSE(gridCells(flat, {2, 2, 2}).ok());
  auto counts = parseGridCounts("4x1x3");
  ASSERT_TRUE(counts.ok());
  EXPECT_EQ(*counts, glm::uvec3(4, 1, 3));
  EXPECT_FALSE(parseGridCounts("4x1").ok());
  EXPECT_FALSE(parseGridCounts("0x1x1").ok());
  EXPECT_FALSE(parseGridCounts("4x1x3x").ok());
}

TEST(GvsConfigJson, ParsesOverridesAndRejectsBadValues) {
  auto c = parseGvsConfig(R"({"random_rays": 5000, "abs_edge_samples": 12, "abs_delta_triangle": 0.01,
                              "reverse_sampling": false})",
                          "gvs.json");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->randomRays, 5000u);
  EXPECT_EQ(c->absEdgeSamples, 12u);
  EXPECT_FLOAT_EQ(c->absDeltaTriangle, 0.01f);
  EXPECT_FALSE(c->reverseSampling);
  EXPECT_EQ(c->rsEdgeSamples, GvsConfig{}.rsEdgeSamples); // untouched keys keep the defaults
  auto again = parseGvsConfig(gvsConfigToJson(*c), "again.json");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->absEdgeSamples, 12u);
  auto err = [](const std::string& text) {
    auto r = parseGvsConfig(text, "gvs.json");
    return r.ok() ? std::string("(ok)") : r.error().message;
  };
  EXPECT_EQ(err("[1]"), "gvs.json: expected an object of GVS++ parameters");
  EXPECT_EQ(err("{"), "gvs.json: not valid JSON");
  EXPECT_EQ(err(R"({"n_rand": 5})"), "gvs.json: unknown parameter \"n_rand\"");
  EXPECT_NE(err(R"({"random_rays": 0})").find("\"random_rays\" must be an integer"), std::string::npos);
  EXPECT_NE(err(R"({"abs_edge_samples": 2.5})").find("must be an integer"), std::string::npos);
  EXPECT_NE(err(R"({"rs_delta_relative": -1})").find("must be a number"), std::string::npos);
  EXPECT_NE(err(R"({"adaptive_border": 1})").find("true or false"), std::string::npos);
}

// Mutated inputs (byte flips, truncations, splices of JSON tokens) never crash or throw, and every
// error is one line naming the file.
TEST(ViewCells, MutatedJsonFailsCleanly) {
  const std::string good = R"({"cells": [{"type": "box", "position": [1, 2, 3], "size": [2, 3, 4],
      "rotation": [0, 90, 0]}, {"type": "rect", "position": [0, 1.7, 0], "size": [5, 6]}]})";
  const char* tokens[] = {"null", "1e400", "-0", "[]", "{}", "\"x\"", "true", "[1,2]", "\"rect\"", ",", ":", "\xff"};
  std::mt19937 rng(9);
  for (int i = 0; i < 3000; ++i) {
    std::string s = good;
    for (int k = 0, edits = 1 + int(rng() % 3); k < edits; ++k) {
      size_t at = rng() % s.size();
      switch (rng() % 3) {
      case 0:
        s[at] = char(rng() % 256);
        break;
      case 1:
        s.resize(at);
        break;
      default:
        s.insert(at, tokens[rng() % std::size(tokens)]);
        break;
      }
      if (s.empty()) s.push_back('{'); // not s = "{": GCC 12 warns falsely (-Wrestrict) there
    }
    auto r = parseViewCells(s, "m.json");
    if (!r.ok()) {
      EXPECT_EQ(r.error().message.rfind("m.json: ", 0), 0u) << r.error().message;
      EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
    } else {
      for (const ViewCell& c : *r) EXPECT_TRUE(validateCell(c, "c").ok());
    }
    auto g = parseGvsConfig(s, "m.json"); // not a config, but it must fail cleanly too
    if (!g.ok()) {
      EXPECT_EQ(g.error().message.rfind("m.json: ", 0), 0u);
    }
  }
}

// Cells must lie within reach of the scene: far-out ones (1e30 aborted Embree) are one-line errors
// naming the file and the cell; cells near or inside the scene pass in any unit.
TEST(ViewCells, CellsFarFromTheSceneAreRejected) {
  Bounds city;
  city.add({-100, 0, -100});
  city.add({100, 40, 100});
  auto cells = [](glm::vec3 position, glm::vec3 size = {4, 2, 4}) {
    ViewCell c;
    c.position = position;
    c.size = size;
    return std::vector<ViewCell>{ViewCell{}, c};
  };
  EXPECT_TRUE(validateCellsForScene(cells({0, 1.7f, -30}), city, "c.json").ok());
  EXPECT_TRUE(validateCellsForScene(cells({5e4f, 0, 0}), city, "c.json").ok()); // 5 km from a 300 m scene
  for (glm::vec3 p : {glm::vec3(1e30f, 0, 0), glm::vec3(0, -1e20f, 0), glm::vec3(1e6f, 0, 0)}) {
    auto s = validateCellsForScene(cells(p), city, "c.json");
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().message.rfind("c.json: cell 1: ", 0), 0u) << s.error().message;
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos);
  }
  EXPECT_FALSE(validateCellsForScene(cells({0, 0, 0}, {1e25f, 1e25f, 1e25f}), city, "c.json").ok());
  // The same scene and cells in millimetres.
  Bounds mm;
  mm.add(city.min * 1000.0f);
  mm.add(city.max * 1000.0f);
  EXPECT_TRUE(validateCellsForScene(cells({5e7f, 0, 0}, {4e3f, 2e3f, 4e3f}), mm, "c.json").ok());
  EXPECT_FALSE(validateCellsForScene(cells({1e9f, 0, 0}, {4e3f, 2e3f, 4e3f}), mm, "c.json").ok());
  // No scene bounds: only the absolute limit of what rays can carry.
  EXPECT_TRUE(validateCellsForScene(cells({1e6f, 0, 0}), Bounds{}, "c.json").ok());
  EXPECT_FALSE(validateCellsForScene(cells({1e30f, 0, 0}), Bounds{}, "c.json").ok());
}
