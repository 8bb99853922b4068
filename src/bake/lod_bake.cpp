#include "mirage/bake/lod_bake.h"

#include "hasher.h"
#include "mirage/lod/baked_mesh.h"

namespace mirage::bake {

uint64_t lodFingerprint(const Scene& scene, const lod::BuildConfig& config) {
  Hasher h;
  h.add(std::span<const char>(std::string_view("mirage build: BakedMesh 1")));
  h.add(config.clusterTriangles), h.add(config.clusterVertices), h.add(config.groupClusters);
  h.add(config.coarseGroupsFromLevel), h.add(config.coarserGroupsFromLevel), h.add(config.stuckRatio);
  h.add(config.normalWeight), h.add(config.rootClusters), h.add(config.maxLevels);
  h.add(uint64_t(scene.meshes.size()));
  for (const Mesh& m : scene.meshes) {
    h.add(std::span<const char>(m.name));
    h.add(std::span<const glm::vec3>(m.positions)), h.add(std::span<const glm::vec3>(m.normals));
    h.add(std::span<const glm::vec2>(m.uv0)), h.add(std::span<const uint32_t>(m.indices));
  }
  return h.digest();
}

Result<lod::LodAsset> bakeLodAsset(const World& world, const Scene& scene, lod::BuildConfig config, const BakeRun& run,
                                   ScheduleReport* report, const UnitProgress& progress) {
  if (config.threads == 0 && world.size() > 1) config.threads = world.threadShare();
  UnitPlan plan;
  if (world.root()) {
    for (const Mesh& m : scene.meshes) plan.costs.push_back(m.triangleCount());
    plan.fingerprint = lodFingerprint(scene, config);
    plan.journal = run.journal;
    plan.resume = run.resume;
  }
  auto input = [&](uint32_t unit) { return lod::encodeMeshUnit(scene, unit); };
  auto bake = [&](uint32_t, std::span<const uint8_t> in) -> Result<std::vector<uint8_t>> {
    auto mesh = lod::bakeMeshUnit(in, config);
    if (!mesh) return mesh.error();
    return lod::encodeBakedMesh(*mesh);
  };
  auto units = runUnits(world, plan, input, bake, report, progress);
  if (!units) return units.error();
  if (!world.root()) return lod::LodAsset{};
  std::vector<lod::BakedMesh> meshes;
  meshes.reserve(units->size());
  for (size_t i = 0; i < units->size(); ++i) {
    std::string where = run.journal.empty() ? "mesh " + std::to_string(i) : run.journal;
    auto mesh = lod::decodeBakedMesh((*units)[i], where);
    if (!mesh) return mesh.error();
    (*units)[i] = {};
    meshes.push_back(std::move(mesh).value());
  }
  return lod::assembleLodAsset(scene, config, std::move(meshes));
}

} // namespace mirage::bake
