// generateScene: the name-based entry point the CLI and tests use.
#include <string>

#include "mirage/io/generate.h"

namespace mirage::io {

Result<CityOptions> cityOptions(uint32_t seed, uint64_t sizeParameter) {
  CityOptions o;
  o.seed = seed;
  if (sizeParameter != 0) {
    if (sizeParameter > 256)
      return makeError("generate city", "blocks " + std::to_string(sizeParameter) + " out of range (1..256)");
    o.blocks = uint32_t(sizeParameter);
  }
  return o;
}

Result<Scene> generateScene(std::string_view kind, uint32_t seed, uint64_t sizeParameter) {
  const std::string where = "generate " + std::string(kind);
  auto outOfRange = [&](const char* what, uint64_t lo, uint64_t hi) {
    return makeError(where, std::string(what) + " " + std::to_string(sizeParameter) + " out of range (" +
                                std::to_string(lo) + ".." + std::to_string(hi) + ")");
  };
  if (kind == "city") {
    auto o = cityOptions(seed, sizeParameter);
    if (!o) return o.error();
    return generateCity(*o);
  }
  if (kind == "terrain") {
    TerrainOptions o;
    o.seed = seed;
    if (sizeParameter != 0) {
      if (sizeParameter < 2 || sizeParameter > 8192) return outOfRange("resolution", 2, 8192);
      o.resolution = uint32_t(sizeParameter);
    }
    return generateTerrain(o);
  }
  if (kind == "blob") {
    BlobOptions o;
    o.seed = seed;
    if (sizeParameter != 0) {
      if (sizeParameter > 11) return outOfRange("subdivisions", 0, 11);
      o.subdivisions = uint32_t(sizeParameter);
    }
    return generateBlob(o);
  }
  if (kind == "layers") {
    LayersOptions o;
    if (sizeParameter != 0) {
      if (sizeParameter > 1024) return outOfRange("layers", 1, 1024);
      o.layers = uint32_t(sizeParameter);
    }
    return generateLayers(o);
  }
  if (kind == "many") {
    auto o = parseManySize(std::to_string(sizeParameter), seed);
    if (!o) return o.error();
    return generateMany(*o);
  }
  return makeError(where, "unknown scene kind (expected city, terrain, blob, layers or many)");
}

} // namespace mirage::io
