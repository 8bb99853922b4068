#pragma once
// The Vulkan ray backend: RayBackend on a ray-tracing pipeline (raygen + closest-hit + any-hit +
// miss; no VK_KHR_ray_query, which the H200 lacks). One BLAS per mesh under a TLAS of instances,
// or one BLAS with one geometry per instance (flattened, transformed at build time). Or, on any
// Vulkan 1.2+ device, a compute-shader traversal of a BVH built on the host (ray_bvh.h). Record
// sets live on the device as bit arrays updated with atomicOr; only first insertions come back.
#include <memory>
#include <span>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/visibility/ray_backend.h"

namespace mirage::gpu {
class Context;
}

namespace mirage::vis {

struct VulkanRayOptions {
  // As EmbreeOptions::Geometry: Auto instances when that saves at least 4x the triangles.
  enum class Geometry { Auto, Flatten, Instance } geometry = Geometry::Auto;
  // Pipeline: the driver's ray-tracing pipeline (hardware RT cores where the GPU has them; on the
  // H200 a software emulation). Compute: a compute shader traversing a binary SAH BVH built on the
  // host with Embree's builder over the flattened triangles (Geometry is ignored), on any device
  // with buffer device addresses. Auto: Compute where the pipeline is missing or emulated in
  // software (a GPU with the pipeline but without ray queries: the H200, where compute traced 2.0x
  // faster, docs/visibility.md) up to 2^26 flattened triangles; else Pipeline.
  enum class Traversal { Auto, Pipeline, Compute } traversal = Traversal::Auto;
  // Compute traversal: a resident grid whose subgroups fetch rays from an atomic counter
  // (Aila-Laine persistent threads) instead of one thread per ray.
  bool persistentThreads = false;
  // Compute traversal: the per-thread stack in shared memory (16 KiB per workgroup) instead of
  // local memory (vis_trace_shared_stack.comp).
  bool sharedStack = false;
  // Compute traversal: the BVH builder's spatial splits (RTC_BUILD_QUALITY_HIGH). Off by default:
  // on gen:city:8 they add 41% leaf triangles and build 12x slower (docs/visibility.md).
  bool spatialSplits = false;
  // Compute traversal: the most triangles per BVH leaf (the SAH decides below it; 1..32).
  uint32_t bvhLeafSize = 4;
  // Compute traversal: children per BVH node, 2 (Aila-Laine nodes), 4 (four boxes tested as
  // vec4 planes, vis_trace_bvh4.comp) or 8 (compressed 80-byte nodes with 8-bit child boxes, after
  // Ylitie et al. 2017, vis_trace_bvh8.comp; leaves of at most 3 triangles); sharedStack only with
  // width 2. 4 by default: on the H200
  // (gen:city:8, 100 M rays) 1.49 G rays/s on host rays and 2.79 G/s generated, vs 1.24 / 1.28 for
  // width 2 and 0.62 / 0.63 through the ray-tracing pipeline.
  uint32_t bvhWidth = 4;
  // Compute traversal, width 8: Ylitie et al.'s triangle postponing (a lane pushes its node's
  // triangles to the stack and goes on down while under a fifth of the subgroup tests triangles,
  // vis_trace_bvh8_postpone.comp). Ties may then resolve differently from run to run.
  bool postponeTriangles = false;
  // trace(): copy the rays into device-local memory and the hits out of it with transfer commands
  // around the launch, instead of the shader reading and writing host-visible memory (PCIe) as it
  // goes. The trace then runs at the rate of rays made on the device; the copies are timed apart
  // (RayTiming::copyMilliseconds) and are not overlapped with the trace.
  bool stagedRays = false;
  // trace(): a batch whose rays all have the interval [0, inf) (every GVS++ ray) is sent as 24-byte
  // (origin, direction) pairs instead of 32-byte rays: rays in host memory are read across PCIe,
  // which caps the trace at its bandwidth over the bytes per ray (docs/visibility.md).
  bool compactRays = true;
  // GVS++ adaptive border and reverse sampling rays made in the shader that traces them
  // (traceExploreRays): the host sends the queued items (16 bytes each, instead of 40 to 129 rays)
  // and reads back discoveries and discontinuities, not hits. Needs 36 bytes of device memory per
  // triangle (up to 2^26 triangles). Off: the host makes the rays (docs/visibility.md).
  bool exploreOnDevice = true;
  // Rays per launch: 2 M rays are 64 MiB of rays and 32 MiB of hits, few enough submissions that
  // their fixed cost stays small beside the trace on a large GPU.
  size_t batchRays = size_t(1) << 21;
};

// Timing of the latest launch (trace() or traceGenerated()).
struct RayTiming {
  double gpuMilliseconds = 0.0;  // the trace dispatch alone (timestamp queries)
  double wallMilliseconds = 0.0; // host copy in, submission, wait, copy out
  double copyMilliseconds = 0.0; // staged rays: the device copies of rays in and hits out
  double copyBytes = 0.0;        // staged rays: the bytes those copies moved
};

// The compute traversal's BVH (zeros for the pipeline traversal).
struct RayBvhStats {
  double buildSeconds = 0.0; // host build (Embree) and layout, not the upload
  size_t nodes = 0;          // inner nodes (64 bytes; 4-wide: 112; 8-wide: 80)
  size_t triangleRefs = 0;   // 48-byte leaf triangles (spatial splits reference some twice)
  uint32_t depth = 0;
};

// Work per ray of the compute traversal, counted by a CPU replica of its 4- or 8-wide BVH walk
// (the same tree, slab tests and visiting order): `bench rays --work` compares host-made and
// device-generated rays, and the widths, without a GPU.
struct TraversalWork {
  double nodes = 0.0;         // inner nodes visited per ray
  double triangleTests = 0.0; // triangles tested per ray
  double hitFraction = 0.0;   // rays with an opaque hit
};
Result<TraversalWork> countTraversalWork(const Scene& scene, std::span<const Ray> rays, uint32_t bvhWidth);

class VulkanRayBackend : public RayBackend {
public:
  // `count` rays generated in the ray-generation shader (uniform origins in [boxMin, boxMax],
  // uniform directions, random stream `seed`): nothing is uploaded and no hits come back; every
  // triangle hit goes into `record` (which may be null). For throughput measurements.
  virtual void traceGenerated(glm::vec3 boxMin, glm::vec3 boxMax, uint64_t count, uint32_t seed,
                              TriangleSet* record) = 0;
  virtual RayTiming lastTiming() const = 0;
  virtual double buildSeconds() const = 0;
  virtual RayBvhStats bvhStats() const = 0;
  // VulkanRayOptions::stagedRays for the following traces.
  virtual void setStagedRays(bool staged) = 0;
  // VulkanRayOptions::compactRays for the following traces.
  virtual void setCompactRays(bool compact) = 0;
};

// Fails when Pipeline is asked of a device without a ray-tracing pipeline. The scene may be freed after; the context
// must outlive the backend.
Result<std::unique_ptr<VulkanRayBackend>> createVulkanBackend(gpu::Context& context, const Scene& scene,
                                                              const VulkanRayOptions& options = {});

} // namespace mirage::vis
