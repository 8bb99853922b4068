// PLY (ascii, binary little/big endian; meshes, strips, point clouds) through every reader that
// takes PLY: the scene importer with and without point clouds, the point-cloud preparation of
// `mirage surfels`, and the surfel PLY reader.
#include "fuzz_support.h"
#include "mirage/io/import.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/surfel_io.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::filesystem::path path = fuzz::writeScratch("in.ply", std::span(data, size));
  Result<Scene> mesh = io::importPly(path);
  if (mesh)
    fuzz::checkImportedScene(*mesh, path);
  else
    fuzz::checkOneLine(mesh.error());

  Result<Scene> any = io::importPly(path, {.allowPointClouds = true});
  if (any) {
    fuzz::checkImportedScene(*any, path);
    if (surfels::isPointCloud(*any)) {
      Result<surfels::ScanPoints> points = surfels::scanPoints(*any);
      if (!points) fuzz::checkOneLine(points.error());
    }
  } else {
    fuzz::checkOneLine(any.error());
  }
  fuzz::check(!mesh || any, "a PLY imported as a mesh is rejected when point clouds are allowed");

  Result<surfels::SurfelCloud> cloud = surfels::readSurfelPly(path);
  if (!cloud) fuzz::checkOneLine(cloud.error());
  return 0;
}
