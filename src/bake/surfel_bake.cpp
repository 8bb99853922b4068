#include "mirage/bake/surfel_bake.h"

#include <chrono>
#include <cstdlib>
#include <cstring>

#include <xxhash.h>

#include "mirage/asset/bytes.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel.h"

namespace mirage::bake {

namespace {

constexpr uint32_t kMeshCloudMagic = 0x4c435342; // "BSCL"

// A MeshCloud as bytes, every field bit for bit (the unit's result and its journal entry).
std::vector<uint8_t> encodeMeshCloud(const MeshCloud& c) {
  const surfels::SurfelCloud& cloud = c.surfels.cloud;
  asset::ByteWriter w;
  w.write(kMeshCloudMagic), w.write(c.surfels.mesh);
  w.write(cloud.box.min), w.write(cloud.box.max);
  w.writeArray(std::span<const surfels::Surfel>(cloud.surfels));
  w.writeArray(std::span<const float>(cloud.radii));
  w.write(cloud.referenceCount), w.write(cloud.referenceMeanSpacing), w.write(cloud.referenceMedianSpacing);
  w.write(c.texels), w.write(c.rho), w.write(c.coverage), w.write(c.seconds);
  return w.take();
}

Result<MeshCloud> decodeMeshCloud(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  MeshCloud c;
  surfels::SurfelCloud& cloud = c.surfels.cloud;
  uint32_t magic = 0;
  r.read(magic), r.read(c.surfels.mesh), r.read(cloud.box.min), r.read(cloud.box.max);
  r.readArray(cloud.surfels), r.readArray(cloud.radii);
  r.read(cloud.referenceCount), r.read(cloud.referenceMeanSpacing), r.read(cloud.referenceMedianSpacing);
  r.read(c.texels), r.read(c.rho), r.read(c.coverage), r.read(c.seconds);
  if (Status s = r.finish(); !s) return s.error();
  if (magic != kMeshCloudMagic || cloud.radii.size() != cloud.surfels.size())
    return makeError(where, "not a mesh's surfel cloud");
  return c;
}

// One unit: the mesh's scene (its SCEN encoding) sampled on this rank's device.
Result<MeshCloud> sampleMesh(gpu::Context& context, uint32_t mesh, std::span<const uint8_t> sceneBytes,
                             const SurfelBakeConfig& config) {
  auto t0 = std::chrono::steady_clock::now();
  auto scene = asset::decodeScene(sceneBytes, "mesh " + std::to_string(mesh));
  if (!scene) return scene.error();
  auto gbuffer = surfels::captureGBuffer(context, *scene, config.capture);
  if (!gbuffer) return gbuffer.error();
  surfels::GpuSamplerConfig sampler = config.sampler;
  sampler.progress = {};
  auto sampled = surfels::sampleOnGpu(context, *gbuffer, sampler);
  if (!sampled) return sampled.error();
  MeshCloud c;
  c.surfels = {mesh, surfels::buildSurfelCloud(gbuffer->texels, sampled->order)};
  surfels::PrefixQuality q = surfels::measurePrefix(gbuffer->texels, sampled->order, uint32_t(c.surfels.cloud.size()));
  c.texels = gbuffer->texels.size();
  c.rho = q.rho, c.coverage = q.coverage;
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

} // namespace

Scene meshScene(const Scene& scene, uint32_t index) {
  Scene sub;
  sub.source = scene.source + " mesh " + std::to_string(index);
  sub.meshes.push_back(scene.meshes[index]);
  sub.meshes[0].material = 0;
  const Mesh& m = scene.meshes[index];
  Material material = m.material < scene.materials.size() ? scene.materials[m.material] : Material{};
  int32_t texture = material.baseColorTexture;
  material.baseColorTexture = -1;
  if (texture >= 0 && size_t(texture) < scene.textures.size()) {
    sub.textures.push_back(scene.textures[size_t(texture)]);
    material.baseColorTexture = 0;
  }
  sub.materials.push_back(material);
  sub.instances.push_back({0, glm::mat4(1.0f)});
  return sub;
}

std::string deviceForRank(const World& world) {
  if (world.size() == 1 || std::getenv("MIRAGE_DEVICE")) return {}; // the user's choice stands
  auto devices = gpu::Context::enumerateDevices();
  if (!devices || devices->empty()) return {};
  for (VkPhysicalDeviceType type :
       {VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU, VK_PHYSICAL_DEVICE_TYPE_CPU}) {
    std::vector<uint32_t> same;
    for (const gpu::DeviceInfo& d : *devices)
      if (d.caps.type == type) same.push_back(d.index);
    if (!same.empty()) return std::to_string(same[size_t(world.localRank()) % same.size()]);
  }
  return {};
}

Result<std::vector<MeshCloud>> bakeSurfelsPerMesh(const World& world, gpu::Context& context, const Scene& scene,
                                                  const SurfelBakeConfig& config, const BakeRun& run,
                                                  ScheduleReport* report, const UnitProgress& progress) {
  // Units: the meshes with triangles (a point cloud's mesh has none), in mesh order.
  std::vector<uint32_t> meshes;
  UnitPlan plan;
  Status planned = Ok{};
  if (world.root()) {
    for (uint32_t i = 0; i < scene.meshes.size(); ++i)
      if (!scene.meshes[i].indices.empty()) {
        meshes.push_back(i);
        plan.costs.push_back(scene.meshes[i].triangleCount());
      }
    if (meshes.empty()) planned = Error{scene.source + ": scene has no triangles to sample"};
    // The fingerprint: every unit's input and the settings.
    asset::ByteWriter w;
    w.writeString("mirage surfels --per-mesh: MeshCloud 1");
    w.write(config.capture.resolution), w.write(config.capture.views), w.write(config.capture.layers);
    w.write(config.sampler.count), w.write(config.sampler.threshold), w.write(uint32_t(config.sampler.discRaster));
    for (uint32_t m : meshes) w.writeBytes(asset::encodeScene(meshScene(scene, m)));
    plan.fingerprint = XXH3_64bits(w.data().data(), w.size());
    plan.journal = run.journal;
    plan.resume = run.resume;
  }
  if (Status all = world.agree(planned); !all) return all.error();
  auto input = [&](uint32_t unit) {
    asset::ByteWriter w;
    w.write(meshes[unit]);
    w.writeBytes(asset::encodeScene(meshScene(scene, meshes[unit])));
    return w.take();
  };
  auto bake = [&](uint32_t, std::span<const uint8_t> in) -> Result<std::vector<uint8_t>> {
    uint32_t mesh = 0;
    std::memcpy(&mesh, in.data(), sizeof mesh);
    auto cloud = sampleMesh(context, mesh, in.subspan(sizeof mesh), config);
    if (!cloud) return cloud.error();
    return encodeMeshCloud(*cloud);
  };
  auto units = runUnits(world, plan, input, bake, report, progress);
  if (!units) return units.error();
  std::vector<MeshCloud> out;
  for (size_t i = 0; i < units->size(); ++i) {
    auto cloud = decodeMeshCloud((*units)[i], run.journal.empty() ? "mesh cloud" : run.journal);
    if (!cloud) return cloud.error();
    out.push_back(std::move(cloud).value());
  }
  return out;
}

} // namespace mirage::bake
