#pragma once
// The Vulkan ray backend's class (private to vulkan_backend.cpp, which builds it and traces host
// rays, and vulkan_gvs_rays.cpp, where it makes the GVS++ rays of a cell: random, border, reverse).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/shaderio/gvs_explore.h"
#include "mirage/visibility/vulkan_backend.h"

namespace mirage::vis::detail {

using gpu::Buffer;
using gpu::Context;
using gpu::DescriptorSet;
using gpu::GpuTimer;
using gpu::MemoryUsage;
using gpu::Unique;

// Exploration rays on the device need every triangle's world-space corners (36 B each: 2.4 GB at
// this count); beyond it the host makes them.
constexpr uint64_t kMaxExploreTriangles = uint64_t(1) << 26;

struct Accel {
  Buffer storage;
  Unique<VkAccelerationStructureKHR> handle;
  VkDeviceAddress address = 0;
};

// A device copy of a host TriangleSet, uploaded again only when the host set changed other than
// through this backend's own insertions (which are mirrored on both sides).
struct DeviceSet {
  const TriangleSet* host = nullptr;
  uint64_t generation = 0;
  size_t count = 0;
  Buffer bits;    // GpuOnly: atomicOr target
  Buffer staging; // Upload
};

// What one launch writes for the host, and its submission: two of them, so the host reads one
// launch's results while the device runs the next (submitCellRays / submitExploreRays).
struct Launch {
  Buffer newIds;          // first insertions into the record set (RtTracePush::newIds)
  Buffer counters;        // RtCounters, read back
  Buffer firstRays;       // claiming launches: the lowest ray of each new triangle, in newIds order
  Buffer source;          // RtCellSource or RtExploreSource
  Buffer items;           // exploration: RtBorderItem[] or RtReverseItem[]
  Buffer discontinuities; // border rays: RtDiscontinuity[]
  std::unique_ptr<GpuTimer> timer;
  Unique<VkFence> done;
  VkCommandBuffer cmd = VK_NULL_HANDLE; // while queued
  // What was queued: the mode (MIRAGE_RT_MODE_*), its slots, the index of its first ray.
  uint32_t mode = 0;
  size_t count = 0;
  uint32_t firstRay = 0;
};

// What every lane of a backend shares (VulkanBackend::sibling): the scene on the device (BVH or
// acceleration structures, world-space corners), the pipelines and the backend's description.
// Read-only once built.
struct DeviceScene {
  size_t triangles = 0;
  double buildSeconds = 0.0;
  bool instanced = false;
  bool compute = false;    // the compute traversal instead of the ray-tracing pipeline
  bool persistent = false; // compute: persistent threads
  std::string name; // vulkan, vulkan-instanced, vulkan-compute[-bvh2|-bvh8][-shared-stack][-postpone][-persistent]
  Buffer vertices, indices, transforms, instances, slots;
  std::vector<Accel> blas;
  Accel tlas;
  DescriptorSet descriptors;
  Unique<VkPipelineLayout> layout;
  Unique<VkPipeline> pipeline;
  Buffer sbt;
  VkStridedDeviceAddressRegionKHR raygenRegion{}, missRegion{}, hitRegion{}, callableRegion{};
  // Compute traversal: RtBvhNode[] and RtBvhTriangle[] (ray_bvh.h), its pipeline.
  Buffer bvhNodes, bvhTriangles;
  Unique<VkPipelineLayout> computeLayout;
  Unique<VkPipeline> computePipeline;
  bool bvhEmpty = true;
  RayBvhStats bvhStats;
  // The gather of claiming launches' first rays (vis_first_rays.comp).
  Unique<VkPipelineLayout> gatherLayout;
  Unique<VkPipeline> gatherPipeline;
  Buffer worldTriangles; // exploration rays: corners per global ID (empty: the backend does not make them)
};

class VulkanBackend final : public VulkanRayBackend {
public:
  VulkanBackend(Context& context, const VulkanRayOptions& options)
      : ctx_(context), batch_(std::max<size_t>(1, options.batchRays)), staged_(options.stagedRays),
        compact_(options.compactRays), explore_(options.exploreOnDevice) {}
  // A lane of `first`'s (sibling()): its settings and scene, its own sets and launches.
  VulkanBackend(const VulkanBackend& first, std::shared_ptr<DeviceScene> scene)
      : ctx_(first.ctx_), sh_(std::move(scene)), batch_(first.batch_), staged_(first.staged_), compact_(first.compact_),
        explore_(first.explore_) {
    createLane();
  }
  ~VulkanBackend() override {
    // This lane's queued launches only: other lanes may still be tracing.
    for (Launch& L : launches_)
      if (L.cmd) {
        const VkFence done = L.done.get();
        vkWaitForFences(ctx_.device(), 1, &done, VK_TRUE, UINT64_MAX);
        ctx_.freeOneShot(L.cmd);
      }
  }

  std::string_view name() const override { return sh_->name; }
  size_t triangleCount() const override { return sh_->triangles; }
  size_t preferredBatchRays() const override { return batch_; }
  RayTiming lastTiming() const override { return timing_; }
  double buildSeconds() const override { return sh_->buildSeconds; }
  RayBvhStats bvhStats() const override { return sh_->bvhStats; }
  void setStagedRays(bool staged) override { staged_ = staged; }
  void setCompactRays(bool compact) override { compact_ = compact; }

  Status build(const Scene& scene, const VulkanRayOptions& options);
  void trace(std::span<const Ray> rays, std::span<Hit> hits, const TraceSets& sets) override;
  void traceGenerated(glm::vec3 boxMin, glm::vec3 boxMax, uint64_t count, uint32_t seed, TriangleSet* record) override;
  bool traceCellRays(const CellRaySource& source, size_t count, TriangleSet& record,
                     std::vector<FirstHit>& out) override;
  bool traceExploreRays(const ExploreRaySource& source, TriangleSet& record, ExploreResult& out) override;
  size_t maxQueued() const override { return launches_.size(); }
  bool submitCellRays(const CellRaySource& source, size_t count, TriangleSet& record) override;
  bool submitExploreRays(const ExploreRaySource& source, TriangleSet& record) override;
  void collect(TriangleSet& record, ExploreResult& out) override;
  std::unique_ptr<RayBackend> sibling() override;
  size_t preferredLanes() const override { return ctx_.caps().type == VK_PHYSICAL_DEVICE_TYPE_CPU ? 1 : 2; }

private:
  Accel buildAccel(VkAccelerationStructureTypeKHR type, std::span<const VkAccelerationStructureGeometryKHR> geometries,
                   std::span<const uint32_t> primitives, const char* name);
  void buildAccelerationStructures(const Scene& scene, std::span<const uint64_t> offsets);
  void createPipeline();
  Status buildCompute(const Scene& scene, const VulkanRayOptions& options);
  void ensureCapacity(Buffer& buffer, size_t bytes, VkBufferUsageFlags usage, MemoryUsage memory, const char* name);
  bool prepareSet(DeviceSet& set, const TriangleSet* host);
  // A launch of `push` into `L`'s outputs. stagedRays > 0: copy that many rays (rayBytes each)
  // into raysDevice_ first and their hits out of hitsDevice_ after. cellMode: a claiming launch
  // (cell or exploration rays: the record set's copy `before_`, firstRay_, the gather pass).
  void cmdLaunch(VkCommandBuffer cmd, Launch& L, shaderio::RtTracePush push, bool uploadRecord, bool uploadRequire,
                 bool cellMode, size_t stagedRays, size_t rayBytes);
  // Submitted and waited for, into launches_[0] (nothing may be queued).
  void launch(shaderio::RtTracePush push, bool uploadRecord, bool uploadRequire, size_t stagedRays = 0,
              size_t rayBytes = sizeof(Ray));
  // A claiming launch queued into the next free Launch; false when none is free.
  bool submitClaiming(shaderio::RtTracePush push, TriangleSet& record, uint32_t firstRay, size_t count);
  Launch& nextLaunch() { return launches_[(oldest_ + queued_) % launches_.size()]; }
  void readTiming(const Launch& L);
  void collectNew(TriangleSet* record);
  // After a claiming launch (cell or exploration rays): first insertions into `record`, and a
  // FirstHit (offset by `firstRay`) for each that was some ray's closest or see-through hit.
  void collectClaims(const Launch& L, TriangleSet& record, uint32_t firstRay, std::vector<FirstHit>& out);
  void uploadWorldTriangles(const Scene& scene, std::span<const uint64_t> offsets);
  // This lane's sets, launches and first-ray buffers (build, and every sibling).
  void createLane();

  Context& ctx_;
  std::shared_ptr<DeviceScene> sh_ = std::make_shared<DeviceScene>();
  size_t batch_;
  bool staged_;  // trace(): rays and hits through device-local copies (VulkanRayOptions::stagedRays)
  bool compact_; // trace(): 24-byte rays where the interval is [0, inf) (VulkanRayOptions::compactRays)
  bool explore_; // traceExploreRays (VulkanRayOptions::exploreOnDevice)
  Buffer rays_, hits_, counters_;
  Buffer raysDevice_, hitsDevice_; // staged traces: device-local copies of rays_ and hits_
  // Claiming launches: the record set as the launch began and the lowest ray per triangle (the
  // entries of a launch's new triangles are gathered into its Launch::firstRays, in newIds order:
  // vis_first_rays.comp).
  Buffer before_, firstRay_;
  DeviceSet record_, require_;
  Buffer exploreRays_;           // tests (traceExploreRays): the exploration rays made
  bool keepExploreRays_ = false; // the next exploration launch writes exploreRays_
  bool firstRayValid_ = false;   // firstRay_ holds ~0u for every triangle outside the record set
  std::array<Launch, 2> launches_;
  size_t oldest_ = 0, queued_ = 0; // launches_[oldest_] is the oldest of `queued_` queued launches
  RayTiming timing_;
};

} // namespace mirage::vis::detail
