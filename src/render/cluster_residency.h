#pragma once
// GPU residency of the cluster renderer (docs/render.md, "Residency"): the page pool, the tables
// the selection reads, the per-slot staging and feedback readback, and the CPU manager deciding
// what they hold (lod/residency.h). Private to the renderer (cluster_residency.cpp).
#include <vector>

#include "mirage/gpu/memory.h"
#include "mirage/lod/residency.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/shaderio/cluster.h"

namespace mirage::render {

struct ClusterSceneData;

struct ClusterResidency {
  lod::ResidencyManager manager;
  PageSource source;
  std::vector<uint32_t> pageMesh, pageLocal; // per global page: its mesh and its page in the mesh
  std::vector<uint32_t> meshClusterOffset;   // per mesh: its first global cluster
  // One pool slot: vertices, vertex ids and triangles (a multiple of 4: slots start on index words).
  uint32_t slotVertices = 0, slotClusterVertices = 0, slotTriangles = 0;
  uint64_t slotBytes = 0;
  uint32_t slots = 0;
  uint64_t budgetBytes = 0;
  std::vector<uint32_t> pageSlot;            // per global page: its slot, MIRAGE_PAGE_NONE when not resident
  std::vector<uint32_t> freeSlots;           // a stack
  std::vector<shaderio::GpuCluster> records; // every cluster's record; offsets set when its page loads
  gpu::Buffer clusterPages, pageSlots, feedback;
  bool rootsStaged = false; // the first recorded frame uploads the root pages
  bool poolUnzeroed = true; // the first frame zeroes the pool (records of missing pages point at slot 0)

  // Per frame slot: the staging of its uploads and their copies (recorded by cmdUpload), its
  // feedback readback, the resident pages when it was recorded, and its figures.
  struct Slot {
    gpu::Buffer staging, readback;
    std::vector<VkBufferCopy> vertices, clusterVertices, indices, records, table;
    std::vector<uint8_t> resident;
    ResidencyStats stats;
  } frame[kMaxFramesInFlight];
  std::vector<float> feedbackHost; // the last collected frame's feedback, not yet acted on
  bool haveFeedback = false;

  ClusterResidency(lod::ResidencyManager m) : manager(std::move(m)) {}
};

// Builds the residency of `asset` into `scene` (whose vertices, vertex ids and indices become the
// pool): slot sizes from the tables and the DAGs, the manager with the root pages resident (their
// uploads happen in the first frame), the GPU tables.
Result<std::unique_ptr<ClusterResidency>> createClusterResidency(gpu::Context& ctx, const lod::LodAsset& asset,
                                                                 const ClusterResidencySettings& settings,
                                                                 ClusterSceneData& scene,
                                                                 std::vector<shaderio::GpuCluster> records);

} // namespace mirage::render
