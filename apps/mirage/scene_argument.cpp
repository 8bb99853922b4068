// Scene arguments of the commands that render: a file, or gen:KIND[:SIZE[:SEED]].
#include <charconv>

#include <fmt/format.h>

#include "mirage/io/generate.h"
#include "mirage/io/import.h"
#include "mirage/visibility/pvs_cull.h"
#include "mirage/visibility/pvs_storage.h"
#include "render_common.h"

namespace mirage::cli {

Result<Scene> loadSceneArgument(const std::string& argument, const io::ImportOptions& options) {
  if (!argument.starts_with("gen:")) return io::importScene(argument, options);
  // gen:KIND[:SIZE[:SEED]]
  std::vector<std::string> parts;
  size_t start = 4;
  while (true) {
    size_t colon = argument.find(':', start);
    parts.push_back(argument.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  uint64_t size = 0;
  uint32_t seed = 1;
  auto number = [](const std::string& s, auto& out) {
    auto r = std::from_chars(s.data(), s.data() + s.size(), out);
    return r.ec == std::errc() && r.ptr == s.data() + s.size();
  };
  if (parts.size() > 3 || (parts.size() > 1 && !number(parts[1], size)) ||
      (parts.size() > 2 && !number(parts[2], seed)))
    return Error{fmt::format("{}: expected gen:KIND[:SIZE[:SEED]]", argument)};
  return io::generateScene(parts[0], seed, size);
}

Result<Scene> restrictSceneToPvs(const Scene& scene, const vis::PvsData& pvs, const std::string& pvsPath, glm::vec3 eye,
                                 int& cell) {
  if (pvs.sceneTriangles != scene.instancedTriangleCount())
    return makeError(pvsPath, fmt::format("baked for a scene of {} triangles, this one has {}", pvs.sceneTriangles,
                                          scene.instancedTriangleCount()));
  cell = vis::findCell(pvs.cells, eye);
  if (cell < 0)
    return makeError(pvsPath, fmt::format("the camera at ({:.4g}, {:.4g}, {:.4g}) is in none of its {} view cells",
                                          eye.x, eye.y, eye.z, pvs.cells.size()));
  return vis::restrictToPvs(scene, pvs.triangles[size_t(cell)]);
}

} // namespace mirage::cli
