// View-cell JSON (`mirage pvs --cells`). Accepted cells must be valid, survive a JSON round trip,
// and be bakeable: a short GVS++ bake from each (at most 4) against a small blob through Embree,
// which aborts on rays it cannot trace, so every cell the parser accepts must give traceable rays.
#include "fuzz_support.h"
#include "mirage/io/generate.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/view_cell.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const Scene scene = io::generateBlob({.subdivisions = 1});
  static const std::unique_ptr<vis::RayBackend> backend = [] {
    auto b = vis::createEmbreeBackend(scene);
    if (!b) fuzz::fail(b.error().message);
    return std::move(*b);
  }();

  std::string text(reinterpret_cast<const char*>(data), size);
  Result<std::vector<vis::ViewCell>> cells = vis::parseViewCells(text, "cells.json");
  if (!cells) {
    fuzz::checkOneLine(cells.error());
    return 0;
  }
  Result<std::vector<vis::ViewCell>> back = vis::parseViewCells(vis::viewCellsToJson(*cells), "again.json");
  if (!back) fuzz::fail("accepted cells written as JSON are rejected: " + back.error().message);
  fuzz::check(back->size() == cells->size(), "JSON round trip changes the cell count");

  vis::GvsConfig config;
  config.randomRays = 64;
  config.absEdgeSamples = 4;
  config.rsEdgeSamples = config.rsAreaSamples = 2;
  config.maxIterations = 2;
  config.rayBudget = 4096;
  for (size_t i = 0; i < cells->size() && i < 4; ++i) {
    const vis::ViewCell& cell = (*cells)[i];
    fuzz::check(bool(vis::validateCell(cell, "cell")), "an accepted cell fails validateCell");
    fuzz::check((*back)[i].shape == cell.shape && (*back)[i].position == cell.position &&
                    (*back)[i].size == cell.size && (*back)[i].rotation == cell.rotation,
                "JSON round trip changes a cell");
    vis::CellPvs pvs = vis::computeCellPvs(*backend, scene, cell, config);
    for (uint32_t t : pvs.triangles) fuzz::check(t < backend->triangleCount(), "PVS names a missing triangle");
  }
  return 0;
}
