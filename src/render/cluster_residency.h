#pragma once
// GPU residency of the cluster renderer (docs/render.md, "Residency"): the page pool and its unit
// allocator, the tables the selection reads, the background page reads, the per-slot staging and
// feedback readback, and the CPU manager deciding what they hold (lod/residency.h). Private to the
// renderer (cluster_page_pool.cpp: scene tables and page layout; cluster_residency.cpp: frames).
#include <chrono>
#include <deque>
#include <memory>
#include <unordered_map>
#include <vector>

#include "cluster_impl.h"
#include "cluster_lod_tree.h"
#include "mirage/gpu/memory.h"
#include "mirage/lod/page_stream.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/lod/residency.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/shaderio/cluster.h"

namespace mirage::render {

// Milliseconds between laps (ResidencyTimes' phases).
struct PhaseClock {
  std::chrono::steady_clock::time_point last;
  PhaseClock();
  double lap(); // since construction or the last lap
};

// The pool's allocation unit. A page takes whole units, any free ones (its vertices fill units in
// order, then each cluster's vertex ids and indices sit whole within one unit), so the pool never
// fragments and a page wastes at most its last unit's tail plus under one cluster per unit (5.7 %).
// A multiple of 32 (vertices) and of 3 (a cluster's indices start on a triangle: offsets in
// triangles) and 4 (vertex ids); 24 KiB against the dragon's pages of 100-200 KiB in the pool: a
// few percent lost to tails, while slots sized for the largest page lost 40 %.
inline constexpr uint32_t kPoolUnitBytes = 24 * 1024;

// A pool unit holds whole cluster records (GpuCluster), so the pool reads as GpuCluster[] too:
// the record at byte b of the pool has slot (record index) b / sizeof(GpuCluster).
static_assert(kPoolUnitBytes % sizeof(shaderio::GpuCluster) == 0, "pool units hold whole cluster records");
inline constexpr uint32_t kUnitRecords = kPoolUnitBytes / sizeof(shaderio::GpuCluster);

// One page laid out in pool units: unit k's geometry at k * kPoolUnitBytes of `bytes`, its used
// length in unitFill[k] (units holding records only have none); per cluster (in page order) the
// record's offsets into the pool, and the record's own byte in the page's units (after the
// geometry: k * kPoolUnitBytes + byte in unit k; its bytes are staged apart, not in `bytes`).
struct PagePacking {
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> unitFill;
  std::vector<uint32_t> vertexOffset, triangleOffset, recordOffset;
  uint64_t geometryBytes = 0; // vertices, vertex ids and indices
};
// Lays `page` out in pool units. Without `units`, only counts; with them (the pool units to use, at
// least as many as the count), fills `out`. Returns the units it takes.
uint32_t layoutPage(const lod::PageData& page, const uint32_t* units, PagePacking* out);
// The most units a page of these counts can take (from the page table, before it is read).
uint32_t poolUnitsBound(uint32_t vertices, uint32_t vertexIds, uint32_t triangles, uint32_t clusters);

// A page's upload made ready without its pool units (on a reader thread: PageStreamConfig::prepare):
// laid out in units 0..n-1, so its vertex ids and record offsets are local; the upload moves them
// to the units the page holds (a vertex unit holds kPoolUnitBytes / 32 vertices exactly).
struct PreparedPage {
  PagePacking packed;
  uint32_t units = 0;                        // units it takes
  size_t clusterVertices = 0;                // vertex ids (the index's count, checked at upload)
  std::vector<uint32_t> ids;                 // per cluster: its number over every mesh
  std::vector<shaderio::GpuCluster> records; // offsets local; cone, id, page and child page (global)
};
// `page` of mesh `mesh` (its first page `pageBase`, its first cluster `clusterBase` over every mesh).
PreparedPage preparePage(const lod::PageData& data, const lod::PageTable& table, uint32_t mesh, uint32_t page,
                         uint32_t pageBase, uint32_t clusterBase);

// The leaves of a prepared page's clusters in both trees, and the nodes above them, grown to hold
// the clusters' self and culling spheres (the tables give only their parent spheres); the nodes
// that changed are appended to `grown`. A page that arrives again changes nothing.
void growTrees(LodTrees& trees, const PreparedPage& prep, std::vector<uint32_t>& grown);

// The cluster renderer's tables of a paged asset from its page tables alone: the cluster records
// as far as the tables know them (member group bounds, level, mesh; the root pages' spheres), on
// the host only, to build the trees from (the GPU's records arrive with their pages), the level
// table, mesh spheres and bounds from the index, and the hierarchical selections' trees (their
// leaves without the spheres of pages not loaded).
struct PagedSceneTables {
  std::vector<shaderio::GpuCluster> clusters;
  std::vector<shaderio::GpuClusterMesh> meshes;
  std::vector<shaderio::GpuClusterLevel> levels;
  std::vector<Bounds> meshBounds;
  LodTrees trees;
  uint32_t maxMeshClusters = 0;
};
Result<PagedSceneTables> pagedSceneTables(const lod::PagedLodAsset& asset);

// The cluster renderer's scene from those tables, uploaded; the residency keeps the trees' host
// copy to grow them as pages arrive. No geometry and no cluster records: the page pool holds both
// (createClusterResidency).
struct PagedClusterScene {
  ClusterSceneData scene;
  LodTrees trees;
};
Result<PagedClusterScene> uploadPagedClusterScene(gpu::Context& ctx, const lod::PagedLodAsset& asset);

struct ClusterResidency {
  enum class PageState : uint8_t {
    Absent,   // not resident
    Reserved, // resident for the manager, units held, bytes not arrived
    Uploaded, // bytes in the pool (this or an earlier frame); drawn once its dependencies are
  };
  lod::ResidencyManager manager;
  const lod::PagedLodAsset* asset = nullptr;
  std::unique_ptr<lod::PageStream> stream;
  std::vector<uint32_t> pageMesh, pageLocal; // per global page: its mesh and its page in the mesh
  std::vector<uint32_t> meshClusterOffset;   // per mesh: its first global cluster
  uint64_t budgetBytes = 0;
  uint32_t units = 0;
  std::vector<uint32_t> freeUnits;              // a stack
  std::vector<std::vector<uint32_t>> pageUnits; // per page: the units it holds
  std::vector<PageState> state;
  std::vector<uint8_t> reading; // per page: a read asked for and not yet arrived
  std::vector<uint32_t> drawn;  // per page: its first unit while drawn (the GPU table), else MIRAGE_PAGE_NONE
  std::vector<std::vector<uint32_t>> recordSlots; // per uploaded page: its clusters' record slots, page order
  std::vector<uint64_t> geometry;                 // per page: its geometry bytes once uploaded
  uint64_t geometryBytes = 0;
  uint64_t recordBytes = 0;    // the uploaded pages' records in the pool
  std::deque<uint32_t> toRead; // reserved pages whose read waits for room in the stream
  // Per cluster its record's slot while its page is drawn (ClusterFrame::clusterSlotAddress); per
  // page its first unit while drawn; per page the feedback.
  gpu::Buffer clusterSlots, pageSlots, feedback;
  // The LOD BVH and DAG tree as uploaded (ClusterSceneData::lodNodes): an arriving page's self and
  // culling spheres grow its clusters' leaves and the nodes above, which the frame uploads too.
  LodTrees trees;
  bool rootsStaged = false; // the first recorded frame uploads the root pages
  bool poolUnzeroed = true; // the first frame zeroes the pool (no stale bytes a lane past a cluster's end may read)

  // Per frame slot: the staging of its uploads and their copies (recorded by cmdUpload), the
  // staging of its cluster-slot writes (pages drawn or evicted, sized after the manager's step),
  // its feedback readback, the drawn pages when it was recorded, and its figures.
  struct Slot {
    gpu::Buffer staging, slotStaging, readback;
    std::vector<VkBufferCopy> pool, records, table, nodes, clusterSlots;
    // Transfer uploads: per consumed batch, its copies from its device buffer into the pool.
    std::vector<std::pair<const gpu::Buffer*, std::vector<VkBufferCopy>>> fromDevice;
    std::vector<uint8_t> resident;
    ResidencyStats stats;
  } frame[kMaxFramesInFlight];
  std::vector<float> feedbackHost; // the last collected frame's feedback, not yet acted on
  // Async uploads (ClusterResidencySettings::Uploads::Transfer): a frame's arrived pages, their
  // pool bytes in one host buffer copied on the transfer queue into `device`; a later frame whose
  // fence check finds it done moves each page still waiting for it (same units) into the pool.
  struct TransferBatch {
    struct Entry {
      uint32_t page = 0;
      std::vector<uint32_t> units;    // the page's units when staged (vertex ids point there)
      std::vector<VkBufferCopy> pool; // from `device` into the pool
      PreparedPage prep;              // records (bytes dropped)
    };
    gpu::Buffer host, device;
    gpu::Unique<VkFence> done;
    VkCommandBuffer cmd = VK_NULL_HANDLE; // while on the transfer queue
    std::vector<Entry> entries;
    enum class State : uint8_t { Free, Copying, Consumed } state = State::Free;
    uint32_t slot = 0; // Consumed: the frame slot that copies from `device` (free once it is reused)
  };
  gpu::Context* ctx = nullptr;
  bool transferUploads = false;
  std::vector<std::unique_ptr<TransferBatch>> batches;
  std::vector<uint32_t> transit; // per page: its batch + 1 while its bytes are on the transfer queue, else 0
  // Prefetch (ClusterResidencySettings::prefetch): per page, the wanted priority of the view it was
  // computed for, computed again on a camera cut from that view (isCameraCut, or the settings'
  // cameraCut) or with a new size or tau.
  bool prefetch = true;
  std::vector<Instance> instances;  // the scene's, as the renderer read them at creation
  std::vector<glm::vec4> meshReach; // per mesh: a sphere (centre, radius) holding its groups' LOD spheres
  std::vector<float> prefetchHost;
  Camera prefetchCamera;          // the view the prefetch is for
  glm::vec3 prefetchTarget{0.0f}; // viewport width, height, tau
  bool cutPending = false;        // a frame said cameraCut before the prefetch could be computed
  bool haveFeedback = false;

  ClusterResidency(lod::ResidencyManager m) : manager(std::move(m)) {}
  ~ClusterResidency();           // waits for batches still on the transfer queue
  void waitForTransfers() const; // every batch on the transfer queue done (renderConverged's idle wait)
};

// The global cluster id of every record slot of the drawn pages (VisibleCluster::cluster names a
// slot with residency): what the last prepared frame draws from.
std::unordered_map<uint32_t, uint32_t> drawnSlotClusters(const ClusterResidency& r);

// Builds the residency of `asset` into `paged.scene` (whose vertices become the pool; the trees
// move to the residency): page costs from the tables (the root pages' exact), the manager with the
// root pages resident (their uploads happen in the first frame), the GPU tables, the page stream.
Result<std::unique_ptr<ClusterResidency>> createClusterResidency(gpu::Context& ctx, const lod::PagedLodAsset& asset,
                                                                 const ClusterResidencySettings& settings,
                                                                 PagedClusterScene& paged);

} // namespace mirage::render
