// Vulkan ray backend (vulkan_backend.h): acceleration structures, the ray-tracing pipeline and its
// shader binding table, or the compute traversal's BVH (ray_bvh.h) and pipeline; launches over
// host-visible ray and hit buffers.
#include <algorithm>
#include <cassert>
#include <chrono>
#include <cstring>
#include <limits>
#include <thread>

#include <fmt/format.h>

#include "ray_bvh.h"
#include "vulkan_backend_impl.h"

namespace mirage::vis {

namespace {

using namespace gpu;
static_assert(sizeof(shaderio::RtRay) == sizeof(Ray) && sizeof(shaderio::RtHit) == sizeof(Hit));
static_assert(offsetof(Ray, tfar) == offsetof(shaderio::RtRay, tfar) && offsetof(Hit, flags) == 8);
static_assert(sizeof(ExploreRaySource::BorderItem) == sizeof(shaderio::RtBorderItem) &&
              sizeof(ExploreRaySource::ReverseItem) == sizeof(shaderio::RtReverseItem) &&
              sizeof(Discontinuity) == sizeof(shaderio::RtDiscontinuity));
static_assert(kHitNew == MIRAGE_RT_HIT_NEW && kHitMissing == MIRAGE_RT_HIT_MISSING &&
              kHitSeeThroughNew == MIRAGE_RT_HIT_SEE_THROUGH_NEW && kNoHit == MIRAGE_RT_NO_HIT);

constexpr VkShaderStageFlags kRtStages = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR |
                                         VK_SHADER_STAGE_ANY_HIT_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR;

// Persistent threads: workgroups of the resident grid, enough to fill a large GPU (the H200 holds
// about 132 SMs x 2048 threads = 4224 groups of 64 at full occupancy).
constexpr uint32_t kPersistentGroups = 8192;

VkDeviceAddress alignUp(VkDeviceAddress v, VkDeviceAddress a) { return (v + a - 1) / a * a; }

// Work of earlier submissions (uploads, builds, traces) is visible to this command buffer: one
// full barrier per submission, whose cost is nothing beside a build or a launch of millions of rays.
void cmdAfterEarlierSubmissions(VkCommandBuffer cmd) {
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
}

bool seeThroughMesh(const Scene& scene, const Mesh& mesh) {
  return mesh.material < scene.materials.size() && scene.materials[mesh.material].alphaMode != AlphaMode::Opaque;
}

VkTransformMatrixKHR toVk(const glm::mat4& m) {
  VkTransformMatrixKHR t;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) t.matrix[r][c] = m[c][r]; // glm is column-major, Vulkan rows of 4
  return t;
}

// MODE_COMPACT: rays whose interval is [0, inf) (every GVS++ ray) go as (origin, direction).
constexpr size_t kCompactRayBytes = 6 * sizeof(float);

bool compactInterval(std::span<const Ray> rays) {
  return std::all_of(rays.begin(), rays.end(),
                     [](const Ray& r) { return r.tnear == 0.0f && r.tfar == std::numeric_limits<float>::infinity(); });
}

// Written in order into write-combined memory.
void packCompact(std::span<const Ray> rays, float* out) {
  for (const Ray& r : rays) {
    out[0] = r.origin.x;
    out[1] = r.origin.y;
    out[2] = r.origin.z;
    out[3] = r.dir.x;
    out[4] = r.dir.y;
    out[5] = r.dir.z;
    out += 6;
  }
}

} // namespace

namespace detail {

Accel VulkanBackend::buildAccel(VkAccelerationStructureTypeKHR type,
                                std::span<const VkAccelerationStructureGeometryKHR> geometries,
                                std::span<const uint32_t> primitives, const char* name) {
  VkAccelerationStructureBuildGeometryInfoKHR info{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR};
  info.type = type;
  info.flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR; // many rays per build
  info.mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR;
  info.geometryCount = uint32_t(geometries.size());
  info.pGeometries = geometries.data();
  VkAccelerationStructureBuildSizesInfoKHR sizes{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
  vkGetAccelerationStructureBuildSizesKHR(ctx_.device(), VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info,
                                          primitives.data(), &sizes);
  Accel a;
  a.storage = createBuffer(ctx_, sizes.accelerationStructureSize,
                           VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR, MemoryUsage::GpuOnly, name);
  VkAccelerationStructureCreateInfoKHR ci{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR};
  ci.buffer = a.storage.handle();
  ci.size = sizes.accelerationStructureSize;
  ci.type = type;
  VkAccelerationStructureKHR handle;
  MIRAGE_VK_CHECK(vkCreateAccelerationStructureKHR(ctx_.device(), &ci, nullptr, &handle));
  a.handle = Unique<VkAccelerationStructureKHR>(ctx_.device(), handle);

  VkPhysicalDeviceAccelerationStructurePropertiesKHR props{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &props};
  vkGetPhysicalDeviceProperties2(ctx_.physicalDevice(), &p2);
  VkDeviceSize align = std::max<VkDeviceSize>(1, props.minAccelerationStructureScratchOffsetAlignment);
  Buffer scratch = createBuffer(ctx_, sizes.buildScratchSize + align, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                MemoryUsage::GpuOnly, "accel scratch");
  info.dstAccelerationStructure = handle;
  info.scratchData.deviceAddress = alignUp(scratch.address(), align);
  std::vector<VkAccelerationStructureBuildRangeInfoKHR> ranges;
  for (uint32_t n : primitives) ranges.push_back({n, 0, 0, 0});
  const VkAccelerationStructureBuildRangeInfoKHR* rangePtr = ranges.data();
  // barriers: the geometry uploads and any BLAS this build instances have completed.
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    cmdAfterEarlierSubmissions(cmd);
    vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &rangePtr);
  });
  VkAccelerationStructureDeviceAddressInfoKHR ai{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR};
  ai.accelerationStructure = handle;
  a.address = vkGetAccelerationStructureDeviceAddressKHR(ctx_.device(), &ai);
  return a;
}

namespace {

VkAccelerationStructureGeometryKHR triangles(VkDeviceAddress vertices, uint32_t maxVertex, VkDeviceAddress indices,
                                             VkDeviceAddress transform, bool seeThrough) {
  VkAccelerationStructureGeometryKHR g{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
  g.geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR;
  // Opaque geometry skips the any-hit shader; see-through geometry runs it once per triangle.
  g.flags = seeThrough ? VK_GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION_BIT_KHR : VK_GEOMETRY_OPAQUE_BIT_KHR;
  auto& t = g.geometry.triangles;
  t.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR;
  t.vertexFormat = VK_FORMAT_R32G32B32_SFLOAT;
  t.vertexData.deviceAddress = vertices;
  t.vertexStride = sizeof(glm::vec3);
  t.maxVertex = maxVertex;
  t.indexType = VK_INDEX_TYPE_UINT32;
  t.indexData.deviceAddress = indices;
  t.transformData.deviceAddress = transform;
  return g;
}

// Auto takes the compute traversal up to this many flattened triangles (48 B each plus nodes: ~5 GB).
constexpr uint64_t kAutoComputeMaxTriangles = uint64_t(1) << 26;

} // namespace

Status VulkanBackend::build(const Scene& scene, const VulkanRayOptions& options) {
  const DeviceCapabilities& caps = ctx_.caps();
  auto t0 = std::chrono::steady_clock::now();
  std::vector<uint64_t> offsets = triangleOffsets(scene);
  sh_->triangles = offsets.back();
  // Auto: the compute traversal where the pipeline is missing or emulated (a GPU that offers the
  // pipeline but no ray queries has no RT cores: the H200 traced 1.25 G rays/s in compute vs 0.62
  // through its pipeline, docs/visibility.md), unless flattening the instances would not fit.
  bool softwareRt = !caps.rayTracingPipeline || (!caps.rayQuery && caps.type != VK_PHYSICAL_DEVICE_TYPE_CPU);
  sh_->compute = options.traversal == VulkanRayOptions::Traversal::Compute ||
                 (options.traversal == VulkanRayOptions::Traversal::Auto && softwareRt &&
                  (sh_->triangles <= kAutoComputeMaxTriangles || !caps.rayTracingPipeline));
  sh_->persistent = options.persistentThreads;
  if (!sh_->compute && !caps.rayTracingPipeline)
    return Error{fmt::format("vulkan: {} has no ray-tracing pipeline (VK_KHR_ray_tracing_pipeline)", caps.name)};
  if (sh_->triangles >= kNoHit) return makeError(scene.source, "more than 4 G triangles: PVS IDs are 32-bit");
  if (sh_->compute) {
    sh_->name = std::string("vulkan-compute") +
                (options.bvhWidth == 4   ? ""
                 : options.bvhWidth == 8 ? "-bvh8"
                                         : "-bvh2") +
                (options.sharedStack && options.bvhWidth == 2 ? "-shared-stack" : "") +
                (options.postponeTriangles && options.bvhWidth == 8 ? "-postpone" : "") +
                (sh_->persistent ? "-persistent" : "");
    if (auto ok = buildCompute(scene, options); !ok) return ok;
  } else {
    sh_->instanced =
        options.geometry == VulkanRayOptions::Geometry::Instance ||
        (options.geometry == VulkanRayOptions::Geometry::Auto && sh_->triangles >= 4 * scene.meshTriangleCount());
    sh_->name = sh_->instanced ? "vulkan-instanced" : "vulkan";
    buildAccelerationStructures(scene, offsets);
    createPipeline();
  }

  sh_->gatherLayout = createPipelineLayout(ctx_, {}, sizeof(shaderio::RtGatherPush), VK_SHADER_STAGE_COMPUTE_BIT);
  sh_->gatherPipeline = createComputePipeline(ctx_, "vis_first_rays.comp", sh_->gatherLayout);
  createLane();
  if (explore_ && sh_->triangles > 0 && sh_->triangles <= kMaxExploreTriangles) uploadWorldTriangles(scene, offsets);
  sh_->buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Ok{};
}

void VulkanBackend::createLane() {
  // Bit sets, the list of first insertions and the counters exist once per lane.
  const size_t setBytes = (sh_->triangles + 63) / 64 * 8;
  for (DeviceSet* s : {&record_, &require_}) {
    // TRANSFER_SRC: the record set is copied to `before_` at the start of cell-ray launches.
    s->bits = createBuffer(ctx_, setBytes,
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "rt set");
    s->staging = createBuffer(ctx_, setBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "rt set staging");
  }
  // The counters are reset at the start of every launch and copied out at its end: launches run
  // in order, so one copy serves them all.
  counters_ = createBuffer(ctx_, sizeof(shaderio::RtCounters),
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "rt counters");
  for (Launch& L : launches_) {
    L.newIds = createBuffer(ctx_, (sh_->triangles + 1) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Readback,
                            "rt new ids");
    L.counters = createBuffer(ctx_, sizeof(shaderio::RtCounters), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              MemoryUsage::Readback, "rt counters readback");
    L.firstRays = createBuffer(ctx_, (sh_->triangles + 1) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               MemoryUsage::Readback, "rt first rays of new triangles");
    L.source = createBuffer(ctx_, std::max(sizeof(shaderio::RtCellSource), sizeof(shaderio::RtExploreSource)),
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "rt ray source");
    L.timer = std::make_unique<GpuTimer>(ctx_, 3);
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence;
    MIRAGE_VK_CHECK(vkCreateFence(ctx_.device(), &fi, nullptr, &fence));
    L.done = Unique<VkFence>(ctx_.device(), fence);
  }
  before_ = createBuffer(ctx_, setBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                         MemoryUsage::GpuOnly, "rt set before launch");
  const size_t rayBytes = std::max<size_t>(sh_->triangles, 1) * 4;
  firstRay_ = createBuffer(ctx_, rayBytes,
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "rt first ray");
  firstRayValid_ = false;
}

std::unique_ptr<RayBackend> VulkanBackend::sibling() { return std::make_unique<VulkanBackend>(*this, sh_); }

void VulkanBackend::buildAccelerationStructures(const Scene& scene, std::span<const uint64_t> offsets) {
  // Every mesh's vertices and indices once, in two buffers; flattened scenes transform them at
  // build time (transformData), so instances never copy vertices.
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;
  std::vector<size_t> vertexBase, indexBase;
  for (const Mesh& m : scene.meshes) {
    vertexBase.push_back(positions.size());
    indexBase.push_back(indices.size());
    positions.insert(positions.end(), m.positions.begin(), m.positions.end());
    indices.insert(indices.end(), m.indices.begin(), m.indices.end());
  }
  const VkBufferUsageFlags input =
      VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  sh_->vertices = createBufferWithData(ctx_, std::span<const glm::vec3>(positions), input, "rt vertices");
  sh_->indices = createBufferWithData(ctx_, std::span<const uint32_t>(indices), input, "rt indices");
  auto meshGeometry = [&](uint32_t mesh, VkDeviceAddress transform) {
    const Mesh& m = scene.meshes[mesh];
    return triangles(sh_->vertices.address() + vertexBase[mesh] * sizeof(glm::vec3),
                     uint32_t(std::max<size_t>(m.positions.size(), 1) - 1),
                     sh_->indices.address() + indexBase[mesh] * sizeof(uint32_t), transform, seeThroughMesh(scene, m));
  };

  std::vector<shaderio::RtSlot> slots;
  std::vector<VkAccelerationStructureInstanceKHR> instances;
  if (sh_->instanced) {
    std::vector<uint32_t> blasOf(scene.meshes.size(), UINT32_MAX);
    for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
      uint32_t n = uint32_t(scene.meshes[m].triangleCount());
      if (n == 0) continue;
      VkAccelerationStructureGeometryKHR g = meshGeometry(m, 0);
      blasOf[m] = uint32_t(sh_->blas.size());
      sh_->blas.push_back(buildAccel(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, {&g, 1}, {&n, 1}, "rt blas"));
    }
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      const Instance& inst = scene.instances[i];
      if (blasOf[inst.mesh] == UINT32_MAX) continue;
      VkAccelerationStructureInstanceKHR vi{};
      vi.transform = toVk(inst.transform);
      vi.mask = 0xff;
      vi.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
      vi.accelerationStructureReference = sh_->blas[blasOf[inst.mesh]].address;
      instances.push_back(vi);
      slots.push_back({uint32_t(offsets[i]), seeThroughMesh(scene, scene.meshes[inst.mesh]) ? 1u : 0u});
    }
  } else {
    std::vector<VkTransformMatrixKHR> transforms;
    std::vector<size_t> used;
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      if (scene.meshes[scene.instances[i].mesh].triangleCount() == 0) continue;
      transforms.push_back(toVk(scene.instances[i].transform));
      used.push_back(i);
    }
    sh_->transforms =
        createBufferWithData(ctx_, std::span<const VkTransformMatrixKHR>(transforms), input, "rt transforms");
    std::vector<VkAccelerationStructureGeometryKHR> geometries;
    std::vector<uint32_t> counts;
    for (size_t k = 0; k < used.size(); ++k) {
      const Instance& inst = scene.instances[used[k]];
      geometries.push_back(meshGeometry(inst.mesh, sh_->transforms.address() + k * sizeof(VkTransformMatrixKHR)));
      counts.push_back(uint32_t(scene.meshes[inst.mesh].triangleCount()));
      slots.push_back({uint32_t(offsets[used[k]]), seeThroughMesh(scene, scene.meshes[inst.mesh]) ? 1u : 0u});
    }
    if (!geometries.empty()) {
      sh_->blas.push_back(buildAccel(VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, geometries, counts, "rt blas"));
      VkAccelerationStructureInstanceKHR vi{};
      vi.transform = toVk(glm::mat4(1.0f));
      vi.mask = 0xff;
      vi.flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR;
      vi.accelerationStructureReference = sh_->blas[0].address;
      instances.push_back(vi);
    }
  }
  sh_->instances =
      createBufferWithData(ctx_, std::span<const VkAccelerationStructureInstanceKHR>(instances), input, "rt instances");
  sh_->slots = createBufferWithData(ctx_, std::span<const shaderio::RtSlot>(slots), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                    "rt slots");
  VkAccelerationStructureGeometryKHR top{VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR};
  top.geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR;
  top.geometry.instances.sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR;
  top.geometry.instances.data.deviceAddress = sh_->instances.address();
  uint32_t instanceCount = uint32_t(instances.size());
  sh_->tlas = buildAccel(VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR, {&top, 1}, {&instanceCount, 1}, "rt tlas");
}

Status VulkanBackend::buildCompute(const Scene& scene, const VulkanRayOptions& options) {
  if (options.bvhWidth != 2 && options.bvhWidth != 4 && options.bvhWidth != 8)
    return Error{"vulkan: the BVH width must be 2, 4 or 8"};
  const bool wide = options.bvhWidth == 4, compressed = options.bvhWidth == 8;
  auto bvh = detail::buildRayBvh(
      scene, {.spatialSplits = options.spatialSplits, .maxLeafSize = options.bvhLeafSize, .width = options.bvhWidth});
  if (!bvh) return bvh.error();
  sh_->bvhNodes = compressed ? createBufferWithData(ctx_, std::span<const shaderio::RtBvh8Node>(bvh->nodes8),
                                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "rt bvh nodes")
                  : wide     ? createBufferWithData(ctx_, std::span<const shaderio::RtBvh4Node>(bvh->nodes4),
                                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "rt bvh nodes")
                             : createBufferWithData(ctx_, std::span<const shaderio::RtBvhNode>(bvh->nodes),
                                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "rt bvh nodes");
  sh_->bvhTriangles = createBufferWithData(ctx_, std::span<const shaderio::RtBvhTriangle>(bvh->triangles),
                                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "rt bvh triangles");
  sh_->bvhEmpty = bvh->nodes.empty() && bvh->nodes4.empty() && bvh->nodes8.empty();
  sh_->bvhStats = {bvh->buildSeconds,
                   compressed ? bvh->nodes8.size()
                   : wide     ? bvh->nodes4.size()
                              : bvh->nodes.size(),
                   bvh->triangles.size(), bvh->depth};
  sh_->computeLayout = createPipelineLayout(ctx_, {}, sizeof(shaderio::RtTracePush), VK_SHADER_STAGE_COMPUTE_BIT);
  const char* shader = compressed ? (options.postponeTriangles ? "vis_trace_bvh8_postpone.comp" : "vis_trace_bvh8.comp")
                       : wide     ? "vis_trace_bvh4.comp"
                       : options.sharedStack ? "vis_trace_shared_stack.comp"
                                             : "vis_trace.comp";
  sh_->computePipeline = createComputePipeline(ctx_, shader, sh_->computeLayout);
  return Ok{};
}

void VulkanBackend::createPipeline() {
  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1,
                                       VK_SHADER_STAGE_RAYGEN_BIT_KHR, nullptr};
  sh_->descriptors = createDescriptorSet(ctx_, {&binding, 1});
  VkAccelerationStructureKHR tlas = sh_->tlas.handle.get();
  VkWriteDescriptorSetAccelerationStructureKHR asWrite{
      VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR};
  asWrite.accelerationStructureCount = 1;
  asWrite.pAccelerationStructures = &tlas;
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, &asWrite};
  w.dstSet = sh_->descriptors.set;
  w.dstBinding = 0;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
  vkUpdateDescriptorSets(ctx_.device(), 1, &w, 0, nullptr);
  sh_->layout = createPipelineLayout(ctx_, {sh_->descriptors.layout.get()}, sizeof(shaderio::RtTracePush), kRtStages);

  Unique<VkShaderModule> modules[4] = {
      createShaderModule(ctx_, "vis_trace.rgen"), createShaderModule(ctx_, "vis_trace.rmiss"),
      createShaderModule(ctx_, "vis_trace.rchit"), createShaderModule(ctx_, "vis_trace.rahit")};
  const VkShaderStageFlagBits stageBits[4] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                              VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR, VK_SHADER_STAGE_ANY_HIT_BIT_KHR};
  VkPipelineShaderStageCreateInfo stages[4];
  for (int i = 0; i < 4; ++i) {
    stages[i] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    stages[i].stage = stageBits[i];
    stages[i].module = modules[i];
    stages[i].pName = "main";
  }
  // Groups: 0 raygen, 1 miss, 2 the one hit group (every instance and geometry uses record 0).
  VkRayTracingShaderGroupCreateInfoKHR groups[3];
  for (uint32_t g = 0; g < 3; ++g) {
    groups[g] = {VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR};
    groups[g].type =
        g < 2 ? VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR : VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
    groups[g].generalShader = g < 2 ? g : VK_SHADER_UNUSED_KHR;
    groups[g].closestHitShader = g == 2 ? 2 : VK_SHADER_UNUSED_KHR;
    groups[g].anyHitShader = g == 2 ? 3 : VK_SHADER_UNUSED_KHR;
    groups[g].intersectionShader = VK_SHADER_UNUSED_KHR;
  }
  VkRayTracingPipelineCreateInfoKHR ci{VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR};
  ci.stageCount = 4;
  ci.pStages = stages;
  ci.groupCount = 3;
  ci.pGroups = groups;
  ci.maxPipelineRayRecursionDepth = 1;
  ci.layout = sh_->layout;
  VkPipeline pipeline;
  MIRAGE_VK_CHECK(
      vkCreateRayTracingPipelinesKHR(ctx_.device(), VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline));
  sh_->pipeline = Unique<VkPipeline>(ctx_.device(), pipeline);

  // Shader binding table: each region starts at the base alignment and holds one record.
  VkPhysicalDeviceRayTracingPipelinePropertiesKHR rt{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &rt};
  vkGetPhysicalDeviceProperties2(ctx_.physicalDevice(), &p2);
  const VkDeviceSize handleSize = rt.shaderGroupHandleSize;
  const VkDeviceSize stride = alignUp(handleSize, rt.shaderGroupHandleAlignment);
  const VkDeviceSize region = alignUp(stride, rt.shaderGroupBaseAlignment);
  std::vector<uint8_t> handles(3 * handleSize);
  MIRAGE_VK_CHECK(
      vkGetRayTracingShaderGroupHandlesKHR(ctx_.device(), sh_->pipeline, 0, 3, handles.size(), handles.data()));
  sh_->sbt = createBuffer(ctx_, 3 * region + rt.shaderGroupBaseAlignment, VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR,
                          MemoryUsage::Upload, "rt sbt");
  const VkDeviceAddress base = alignUp(sh_->sbt.address(), rt.shaderGroupBaseAlignment);
  for (int g = 0; g < 3; ++g)
    std::memcpy(sh_->sbt.mapped() + (base - sh_->sbt.address()) + g * region, handles.data() + g * handleSize,
                handleSize);
  sh_->raygenRegion = {base, region, region};
  sh_->missRegion = {base + region, stride, stride};
  sh_->hitRegion = {base + 2 * region, stride, stride};
}

void VulkanBackend::ensureCapacity(Buffer& buffer, size_t bytes, VkBufferUsageFlags usage, MemoryUsage memory,
                                   const char* name) {
  if (buffer && buffer.size() >= bytes) return;
  buffer = createBuffer(ctx_, std::max<size_t>(bytes, buffer ? buffer.size() * 2 : 0), usage, memory, name);
}

// True when the device copy must be uploaded (then the staging buffer already holds the words).
bool VulkanBackend::prepareSet(DeviceSet& set, const TriangleSet* host) {
  if (!host) return false;
  size_t count = host->count();
  if (set.host == host && set.generation == host->generation() && set.count == count) return false;
  set.host = host;
  set.generation = host->generation();
  set.count = count;
  const size_t words = std::min((host->capacity() + 63) / 64, size_t(set.staging.size() / 8));
  auto* dst = reinterpret_cast<uint64_t*>(set.staging.mapped());
  for (size_t w = 0; w < words; ++w) dst[w] = host->words()[w].load(std::memory_order_relaxed);
  return true;
}

void VulkanBackend::cmdLaunch(VkCommandBuffer cmd, Launch& L, shaderio::RtTracePush push, bool uploadRecord,
                              bool uploadRequire, bool cellMode, size_t stagedRays, size_t rayBytes) {
  push.slots = sh_->slots.address();
  push.counters = counters_.address();
  push.newIds = L.newIds.address();
  push.newCapacity = uint32_t(sh_->triangles + 1);
  push.bvhNodes = sh_->compute && !sh_->bvhEmpty ? sh_->bvhNodes.address() : 0;
  push.bvhTriangles = sh_->compute && !sh_->bvhEmpty ? sh_->bvhTriangles.address() : 0;
  push.persistent = sh_->compute && sh_->persistent ? 1u : 0u;
  const uint32_t width = std::min(push.count, MIRAGE_RT_LAUNCH_WIDTH);
  const uint32_t height = (push.count + width - 1) / std::max(width, 1u);
  const VkPipelineStageFlags2 stage =
      sh_->compute ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT : VK_PIPELINE_STAGE_2_RAY_TRACING_SHADER_BIT_KHR;
  GpuTimer& timer = *L.timer;
  // barriers: earlier launches' writes to the sets and counters are complete before the copies.
  timer.cmdReset(cmd);
  cmdAfterEarlierSubmissions(cmd);
  VkBufferCopy whole{0, 0, record_.bits.size()};
  if (uploadRecord) vkCmdCopyBuffer(cmd, record_.staging.handle(), record_.bits.handle(), 1, &whole);
  if (uploadRequire) vkCmdCopyBuffer(cmd, require_.staging.handle(), require_.bits.handle(), 1, &whole);
  vkCmdFillBuffer(cmd, counters_.handle(), 0, VK_WHOLE_SIZE, 0);
  if (stagedRays > 0) {
    uint32_t upload = timer.cmdBegin(cmd, "upload", VK_PIPELINE_STAGE_2_TRANSFER_BIT);
    VkBufferCopy bytes{0, 0, stagedRays * rayBytes};
    vkCmdCopyBuffer(cmd, rays_.handle(), raysDevice_.handle(), 1, &bytes);
    timer.cmdEnd(cmd, upload, VK_PIPELINE_STAGE_2_TRANSFER_BIT);
  }
  if (cellMode) {
    // A replaced record set may have cleared triangles whose firstRay entries are still set.
    if (uploadRecord || !firstRayValid_) vkCmdFillBuffer(cmd, firstRay_.handle(), 0, VK_WHOLE_SIZE, ~0u);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    vkCmdCopyBuffer(cmd, record_.bits.handle(), before_.handle(), 1, &whole);
  }
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, stage,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  uint32_t slot = 0;
  if (sh_->compute) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sh_->computePipeline);
    vkCmdPushConstants(cmd, sh_->computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    slot = timer.cmdBegin(cmd, "trace", stage);
    // One thread per ray in rows of MIRAGE_RT_LAUNCH_WIDTH, or a resident grid that loops.
    const uint32_t groupsX = (width + MIRAGE_RT_COMPUTE_GROUP - 1) / MIRAGE_RT_COMPUTE_GROUP;
    if (push.count > 0 && sh_->persistent)
      vkCmdDispatch(cmd, std::min(groupsX * height, kPersistentGroups), 1, 1);
    else if (push.count > 0)
      vkCmdDispatch(cmd, groupsX, height, 1);
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, sh_->pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, sh_->layout, 0, 1, &sh_->descriptors.set, 0,
                            nullptr);
    vkCmdPushConstants(cmd, sh_->layout, kRtStages, 0, sizeof(push), &push);
    slot = timer.cmdBegin(cmd, "trace", stage);
    if (push.count > 0)
      vkCmdTraceRaysKHR(cmd, &sh_->raygenRegion, &sh_->missRegion, &sh_->hitRegion, &sh_->callableRegion, width, height,
                        1);
  }
  timer.cmdEnd(cmd, slot, stage);
  if (cellMode) {
    // The lowest ray of each new triangle, gathered into host-visible memory.
    cmdMemoryBarrier(cmd, stage, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    shaderio::RtGatherPush gather{L.newIds.address(),    counters_.address(),          firstRay_.address(),
                                  L.firstRays.address(), uint32_t(sh_->triangles + 1), 0};
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, sh_->gatherPipeline);
    vkCmdPushConstants(cmd, sh_->gatherLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(gather), &gather);
    vkCmdDispatch(cmd, MIRAGE_RT_GATHER_GROUPS, 1, 1);
  }
  cmdMemoryBarrier(cmd, stage, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                   VK_ACCESS_2_TRANSFER_READ_BIT);
  VkBufferCopy counters{0, 0, sizeof(shaderio::RtCounters)};
  vkCmdCopyBuffer(cmd, counters_.handle(), L.counters.handle(), 1, &counters);
  if (stagedRays > 0) {
    uint32_t readback = timer.cmdBegin(cmd, "readback", VK_PIPELINE_STAGE_2_TRANSFER_BIT);
    VkBufferCopy bytes{0, 0, stagedRays * sizeof(Hit)};
    vkCmdCopyBuffer(cmd, hitsDevice_.handle(), hits_.handle(), 1, &bytes);
    timer.cmdEnd(cmd, readback, VK_PIPELINE_STAGE_2_TRANSFER_BIT);
  }
  cmdMemoryBarrier(cmd, stage | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
}

void VulkanBackend::launch(shaderio::RtTracePush push, bool uploadRecord, bool uploadRequire, size_t stagedRays,
                           size_t rayBytes) {
  assert(queued_ == 0);
  auto t0 = std::chrono::steady_clock::now();
  ctx_.submitAndWait([&](VkCommandBuffer cmd) {
    cmdLaunch(cmd, launches_[0], push, uploadRecord, uploadRequire, false, stagedRays, rayBytes);
  });
  readTiming(launches_[0]);
  timing_.wallMilliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void VulkanBackend::readTiming(const Launch& L) {
  timing_ = {};
  for (const PassTime& pass : L.timer->read())
    (pass.name == "trace" ? timing_.gpuMilliseconds : timing_.copyMilliseconds) += pass.milliseconds;
}

// First insertions made on the device go into the host set too, so both stay equal.
void VulkanBackend::collectNew(TriangleSet* record) {
  if (!record) return;
  shaderio::RtCounters c;
  std::memcpy(&c, launches_[0].counters.mapped(), sizeof(c));
  const auto* ids = reinterpret_cast<const uint32_t*>(launches_[0].newIds.mapped());
  for (uint32_t k = 0; k < std::min<uint32_t>(c.newCount, uint32_t(sh_->triangles + 1)); ++k) record->insert(ids[k]);
  record_.count = record->count();
}

void VulkanBackend::trace(std::span<const Ray> rays, std::span<Hit> hits, const TraceSets& sets) {
  const size_t n = std::min(rays.size(), hits.size());
  RayTiming total;
  for (size_t begin = 0; begin < n; begin += batch_) {
    const size_t count = std::min(batch_, n - begin);
    auto t0 = std::chrono::steady_clock::now();
    ensureCapacity(rays_, count * sizeof(Ray), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                   MemoryUsage::Upload, "rt rays");
    ensureCapacity(hits_, count * sizeof(Hit), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                   MemoryUsage::Readback, "rt hits");
    const std::span<const Ray> batch = rays.subspan(begin, count);
    const bool compact = compact_ && compactInterval(batch);
    const size_t rayBytes = compact ? kCompactRayBytes : sizeof(Ray);
    if (compact)
      packCompact(batch, reinterpret_cast<float*>(rays_.mapped()));
    else
      std::memcpy(rays_.mapped(), batch.data(), count * sizeof(Ray));
    shaderio::RtTracePush push{};
    push.rays = rays_.address();
    push.hits = hits_.address();
    if (staged_) {
      ensureCapacity(raysDevice_, count * sizeof(Ray),
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                     "rt rays (device)");
      ensureCapacity(hitsDevice_, count * sizeof(Hit),
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::GpuOnly,
                     "rt hits (device)");
      push.rays = raysDevice_.address();
      push.hits = hitsDevice_.address();
    }
    push.record = sets.record ? record_.bits.address() : 0;
    push.require = sets.require ? require_.bits.address() : 0;
    push.count = uint32_t(count);
    push.mode = compact ? MIRAGE_RT_MODE_COMPACT : MIRAGE_RT_MODE_BUFFER;
    push.onlyRequired = sets.onlyRequired && sets.require ? 1u : 0u;
    bool uploadRecord = prepareSet(record_, sets.record);
    bool uploadRequire = prepareSet(require_, sets.require);
    launch(push, uploadRecord, uploadRequire, staged_ ? count : 0, rayBytes);
    std::memcpy(hits.data() + begin, hits_.mapped(), count * sizeof(Hit));
    collectNew(sets.record);
    total.gpuMilliseconds += timing_.gpuMilliseconds;
    total.copyMilliseconds += timing_.copyMilliseconds;
    total.copyBytes += staged_ ? double(count * (rayBytes + sizeof(Hit))) : 0.0;
    total.wallMilliseconds += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  timing_ = total;
}

void VulkanBackend::traceGenerated(glm::vec3 boxMin, glm::vec3 boxMax, uint64_t count, uint32_t seed,
                                   TriangleSet* record) {
  RayTiming total;
  for (uint64_t done = 0; done < count;) {
    // Launches of up to 2^30 rays (the smallest maxRayDispatchInvocationCount the spec allows).
    uint32_t n = uint32_t(std::min<uint64_t>(count - done, uint64_t(1) << 30));
    auto t0 = std::chrono::steady_clock::now();
    shaderio::RtTracePush push{};
    push.record = record ? record_.bits.address() : 0;
    push.boxMin = boxMin;
    push.boxMax = boxMax;
    push.count = n;
    push.mode = MIRAGE_RT_MODE_GENERATED;
    push.seed = seed + uint32_t(done >> 30) * 0x9e3779b9u;
    launch(push, prepareSet(record_, record), false);
    collectNew(record);
    total.gpuMilliseconds += timing_.gpuMilliseconds;
    total.wallMilliseconds += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    done += n;
  }
  timing_ = total;
}

} // namespace detail

Result<TraversalWork> countTraversalWork(const Scene& scene, std::span<const Ray> rays, uint32_t bvhWidth) {
  if (bvhWidth != 4 && bvhWidth != 8) return Error{"traversal work: the BVH width must be 4 or 8"};
  auto bvh = detail::buildRayBvh(scene, {.width = bvhWidth});
  if (!bvh) return bvh.error();
  const size_t threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<TraversalWork> parts(threads);
  std::vector<std::thread> workers;
  for (size_t w = 0; w < threads; ++w)
    workers.emplace_back([&, w] {
      for (size_t i = w; i < rays.size(); i += threads) {
        detail::CpuTraceResult r = detail::cpuTrace(*bvh, rays[i].origin, rays[i].dir, rays[i].tnear, rays[i].tfar);
        parts[w].nodes += r.nodes;
        parts[w].triangleTests += r.triangleTests;
        parts[w].hitFraction += r.triangle != MIRAGE_RT_NO_HIT;
      }
    });
  for (std::thread& t : workers) t.join();
  TraversalWork total;
  for (const TraversalWork& p : parts) {
    total.nodes += p.nodes;
    total.triangleTests += p.triangleTests;
    total.hitFraction += p.hitFraction;
  }
  const double n = double(std::max<size_t>(1, rays.size()));
  return TraversalWork{total.nodes / n, total.triangleTests / n, total.hitFraction / n};
}

Result<std::unique_ptr<VulkanRayBackend>> createVulkanBackend(gpu::Context& context, const Scene& scene,
                                                              const VulkanRayOptions& options) {
  auto backend = std::make_unique<detail::VulkanBackend>(context, options);
  if (auto ok = backend->build(scene, options); !ok) return ok.error();
  return std::unique_ptr<VulkanRayBackend>(std::move(backend));
}

} // namespace mirage::vis
