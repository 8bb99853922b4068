// Inputs of the runtime: scene arguments (a file, or gen:KIND[:SIZE[:SEED]]), .mrg contents, surfel
// clouds, and the triangle PVS of a view cell.
#include "mirage/runtime/scene_argument.h"

#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/io/generate.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_cull.h"

namespace mirage::runtime {

std::optional<Result<io::ManyOptions>> manySceneArgument(const std::string& argument) {
  if (!argument.starts_with("gen:many")) return std::nullopt;
  std::string_view rest = std::string_view(argument).substr(8);
  if (!rest.empty() && rest[0] != ':') return std::nullopt; // another kind ("gen:manyfold"): not ours
  if (!rest.empty()) rest.remove_prefix(1);
  size_t colon = rest.find(':');
  uint32_t seed = 1;
  if (colon != std::string_view::npos) {
    std::string_view s = rest.substr(colon + 1);
    auto r = std::from_chars(s.data(), s.data() + s.size(), seed);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size() || s.empty())
      return Result<io::ManyOptions>(Error{fmt::format("{}: expected gen:many[:COUNT[xTRIANGLES][:SEED]]", argument)});
  }
  return io::parseManySize(rest.substr(0, colon), seed);
}

Result<GenArgument> parseGenArgument(const std::string& argument) {
  // gen:KIND[:SIZE[:SEED]]
  std::vector<std::string> parts;
  size_t start = 4;
  while (true) {
    size_t colon = argument.find(':', start);
    parts.push_back(argument.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  GenArgument out;
  auto number = [](const std::string& s, auto& value) {
    auto r = std::from_chars(s.data(), s.data() + s.size(), value);
    return r.ec == std::errc() && r.ptr == s.data() + s.size();
  };
  if (!argument.starts_with("gen:") || parts.size() > 3 || (parts.size() > 1 && !number(parts[1], out.size)) ||
      (parts.size() > 2 && !number(parts[2], out.seed)))
    return Error{fmt::format("{}: expected gen:KIND[:SIZE[:SEED]]", argument)};
  out.kind = parts[0];
  return out;
}

Result<mirage::Scene> loadSceneArgument(const std::string& argument, const io::ImportOptions& options) {
  if (!argument.starts_with("gen:")) return io::importScene(argument, options);
  if (auto many = manySceneArgument(argument)) {
    if (!*many) return many->error();
    return io::generateMany(**many);
  }
  auto gen = parseGenArgument(argument);
  if (!gen) return gen.error();
  return io::generateScene(gen->kind, gen->seed, gen->size);
}

bool isMrgPath(const std::string& input) { return input.size() > 4 && input.ends_with(".mrg"); }

MrgContents mrgContents(const std::string& input) {
  MrgContents m;
  if (!isMrgPath(input)) return m;
  auto reader = asset::AssetReader::open(input);
  if (!reader) return m; // the loader reports the error
  m.clusterDags = reader->find(asset::chunk::ClusterDag).has_value();
  m.surfels = reader->find(asset::chunk::Surfels).has_value();
  m.pvs = reader->find(asset::chunk::Visibility).has_value();
  m.scene = reader->find(asset::chunk::Scene).has_value();
  return m;
}

Result<surfels::SurfelCloud> loadSurfelCloud(const std::string& path, Material& material) {
  material.metallicFactor = 0.0f;
  material.roughnessFactor = 0.6f;
  if (path.ends_with(".ply")) return surfels::readSurfelPly(path);
  if (!path.ends_with(".mrg")) return makeError(path, "surfel input must be a .mrg with a SURF chunk or a surfel .ply");
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  if (!reader->find(asset::chunk::Surfels))
    return makeError(path, "has no SURF chunk (write one with: mirage surfels INPUT -o FILE.mrg)");
  auto m = surfels::readSurfelChunk(*reader, *reader->find(asset::chunk::Surfels));
  if (!m) return m.error();
  if (m->cloud.size() == 0) return makeError(path, "SURF chunk holds no surfels");
  if (reader->find(asset::chunk::Scene)) {
    auto sceneBytes = reader->readChunk(asset::chunk::Scene);
    if (!sceneBytes) return sceneBytes.error();
    auto scene = asset::decodeScene(*sceneBytes, path);
    if (!scene) return scene.error();
    if (!scene->meshes.empty() && scene->meshes[0].material < scene->materials.size())
      material = scene->materials[scene->meshes[0].material];
  }
  return std::move(m->cloud);
}

Status checkPvsScene(const mirage::Scene& scene, const vis::PvsData& pvs, const std::string& pvsPath) {
  if (pvs.sceneTriangles != scene.instancedTriangleCount())
    return makeError(pvsPath, fmt::format("baked for a scene of {} triangles, this one has {}", pvs.sceneTriangles,
                                          scene.instancedTriangleCount()));
  return Ok{};
}

Result<int> pvsCellOf(const vis::PvsData& pvs, const std::string& pvsPath, glm::vec3 eye) {
  int cell = vis::findCell(pvs.cells, eye);
  if (cell < 0)
    return makeError(pvsPath, fmt::format("the camera at ({:.4g}, {:.4g}, {:.4g}) is in none of its {} view cells",
                                          eye.x, eye.y, eye.z, pvs.cells.size()));
  return cell;
}

Result<mirage::Scene> restrictSceneToPvs(const mirage::Scene& scene, const vis::PvsData& pvs,
                                         const std::string& pvsPath, glm::vec3 eye, int& cell) {
  if (auto st = checkPvsScene(scene, pvs, pvsPath); !st) return st.error();
  auto found = pvsCellOf(pvs, pvsPath, eye);
  if (!found) return found.error();
  cell = *found;
  return vis::restrictToPvs(scene, pvs.triangles[size_t(cell)]);
}

std::array<render::Camera, 4> cellViewCameras(const vis::ViewCell& cell) {
  std::array<render::Camera, 4> cams;
  for (int v = 0; v < 4; ++v) {
    float a = float(v) * 1.5707963f;
    cams[size_t(v)].eye = cell.position;
    cams[size_t(v)].target = cell.position + glm::vec3(std::cos(a), 0.0f, std::sin(a));
    cams[size_t(v)].fovYDegrees = 70.0f;
  }
  return cams;
}

} // namespace mirage::runtime
