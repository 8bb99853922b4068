// GPU residency of paged DAGs (docs/render.md, "Residency"): the page pool and its tables, the
// reads, uploads and publication each frame records, the feedback each frame reads back, and the
// manager between them.
#include "cluster_residency.h"

#include <algorithm>
#include <cassert>
#include <cstring>
#include <thread>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/commands.h"
#include "mirage/render/camera.h"
#include "mirage/shaderio/lod_paging.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;
using PageState = ClusterResidency::PageState;

ResidencyTimes& ResidencyTimes::operator+=(const ResidencyTimes& o) {
  takeMs += o.takeMs, uploadMs += o.uploadMs, prefetchMs += o.prefetchMs, stepMs += o.stepMs;
  requestMs += o.requestMs, publishMs += o.publishMs, setupMs += o.setupMs, submitMs += o.submitMs;
  collectMs += o.collectMs, readbackMs += o.readbackMs, readWaitMs += o.readWaitMs, decodeMs += o.decodeMs;
  layoutMs += o.layoutMs;
  return *this;
}

PhaseClock::PhaseClock() : last(std::chrono::steady_clock::now()) {}
double PhaseClock::lap() {
  auto now = std::chrono::steady_clock::now();
  double ms = std::chrono::duration<double, std::milli>(now - last).count();
  last = now;
  return ms;
}

Result<std::unique_ptr<ClusterResidency>> createClusterResidency(Context& ctx, const lod::PagedLodAsset& asset,
                                                                 const ClusterResidencySettings& settings,
                                                                 PagedClusterScene& paged) {
  const std::string& file = asset.reader->path();
  ClusterSceneData& scene = paged.scene;
  std::vector<uint32_t> pageMesh, pageLocal, meshClusterOffset;
  std::vector<const lod::PageTable*> tables;
  uint32_t clusterBase = 0;
  for (uint32_t m = 0; m < asset.meshes.size(); ++m) {
    const lod::PageTable& t = asset.meshes[m].table;
    tables.push_back(&t);
    meshClusterOffset.push_back(clusterBase);
    clusterBase += uint32_t(t.clusterPage.size());
    for (uint32_t p = 0; p < t.pages.size(); ++p) pageMesh.push_back(m), pageLocal.push_back(p);
  }
  // Costs: the root pages' exact units (they are here), the others' bound from the table (exact
  // once read: ClusterResidency::arrive).
  auto pageBytes = [&](uint32_t m, uint32_t p) -> uint64_t {
    const lod::PageTable& t = asset.meshes[m].table;
    if (p < t.rootPageCount) return uint64_t(layoutPage(asset.rootPages[m][p], nullptr, nullptr)) * kPoolUnitBytes;
    const lod::PageInfo& info = t.pages[p];
    return uint64_t(poolUnitsBound(info.vertexCount, asset.meshes[m].rest.pageClusterVertices[p], info.triangleCount,
                                   info.clusterCount)) *
           kPoolUnitBytes;
  };
  // Every record slot (kUnitRecords per unit) numbered below MIRAGE_PAGE_NONE: pools under 512 GiB.
  uint32_t units = uint32_t(std::min<uint64_t>(settings.budgetBytes / kPoolUnitBytes, (UINT32_MAX - 1) / kUnitRecords));
  lod::ResidencyGraph graph = lod::residencyGraph(std::span<const lod::PageTable* const>(tables), pageBytes);
  lod::ResidencyConfig config{uint64_t(units) * kPoolUnitBytes, std::max(settings.maxUploadsPerFrame, 1u)};
  auto manager = lod::ResidencyManager::create(std::move(graph), config);
  if (!manager)
    return Error{
        fmt::format("{}: --gpu-budget: {} (pool units of {} bytes)", file, manager.error().message, kPoolUnitBytes)};
  auto r = std::make_unique<ClusterResidency>(std::move(*manager));
  r->asset = &asset;
  r->trees = std::move(paged.trees);
  r->pageMesh = std::move(pageMesh);
  r->pageLocal = std::move(pageLocal);
  r->meshClusterOffset = std::move(meshClusterOffset);
  r->budgetBytes = settings.budgetBytes;
  r->prefetch = settings.prefetch;
  if (r->prefetch) {
    r->instances = asset.scene.instances;
    for (const lod::PagedMesh& pm : asset.meshes) { // a sphere holding every group's LOD sphere
      const Bounds& box = pm.rest.positionBounds;
      glm::vec3 centre = box.empty() ? glm::vec3(0.0f) : box.center();
      float reach = 0.0f;
      for (const lod::LodBounds& b : pm.table.groupBounds)
        reach = std::max(reach, glm::length(b.center - centre) + b.radius);
      r->meshReach.push_back(glm::vec4(centre, reach));
    }
  }
  r->units = units;
  for (uint32_t u = units; u-- > 0;) r->freeUnits.push_back(u);
  uint32_t pages = uint32_t(r->pageMesh.size());
  r->pageUnits.resize(pages);
  r->state.assign(pages, PageState::Absent);
  r->reading.assign(pages, 0);
  r->drawn.assign(pages, MIRAGE_PAGE_NONE);
  r->recordSlots.resize(pages);
  r->geometry.assign(pages, 0);
  r->transit.assign(pages, 0);
  r->ctx = &ctx;
  using Uploads = ClusterResidencySettings::Uploads;
  // Auto: in the frame. Measured on the H100 (gen:many:64x200000, 256 MB, fly:30): the transfer queue
  // took no GPU time off the converging frames and each page a frame longer to full quality.
  r->transferUploads = settings.uploads == Uploads::Transfer;

  // Per cluster, numbered over every mesh, its record's slot: none until its page is drawn. The
  // only per-cluster table beside the trees: the record (page, child page, bounds, cone) comes
  // with the page.
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  constexpr VkBufferUsageFlags kCopied = kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  r->clusterSlots = createBufferWithData<uint32_t>(ctx, std::vector<uint32_t>(clusterBase, MIRAGE_PAGE_NONE), kCopied,
                                                   "residency cluster slots");
  r->pageSlots = createBufferWithData<uint32_t>(ctx, r->drawn, kCopied, "residency drawn pages");
  r->feedback = createBuffer(ctx, pages * 4ull, kCopied, MemoryUsage::GpuOnly, "residency feedback");
  for (ClusterResidency::Slot& s : r->frame)
    s.readback = createBuffer(ctx, pages * 4ull, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback,
                              "residency feedback readback");
  // The pool takes the place of the scene's geometry and cluster records (vertices, vertex ids,
  // index words and records alike), with one full cluster of index padding past its end, as
  // uploadClusterScene pads the index array.
  scene.vertices = createBuffer(ctx, uint64_t(std::max(units, 1u)) * kPoolUnitBytes + MIRAGE_CLUSTER_MAX_TRIANGLES * 3,
                                kCopied, MemoryUsage::GpuOnly, "residency page pool");
  lod::PageStreamConfig streamConfig;
  streamConfig.maxInFlight = std::max(settings.maxReadsInFlight, 1u);
  // Readers: 4 at least (a page's read may wait on a disk or a link rather than a core), up to the
  // cores the render thread and the driver leave, 12 at most.
  streamConfig.threads = std::clamp(std::thread::hardware_concurrency(), 6u, 14u) - 2u;
  // Each page's upload is laid out on the reader thread that decoded it (the decoded page dropped).
  streamConfig.prepare = [meshes = &asset.meshes, pageOffset = r->manager.graph().pageOffset,
                          clusterOffset = r->meshClusterOffset](lod::StreamedPage& sp) {
    if (sp.mesh >= meshes->size() || sp.page >= (*meshes)[sp.mesh].table.pages.size()) return;
    sp.prepared =
        preparePage(sp.data, (*meshes)[sp.mesh].table, sp.mesh, sp.page, pageOffset[sp.mesh], clusterOffset[sp.mesh]);
    sp.data = {};
  };
  r->stream = std::make_unique<lod::PageStream>(*asset.reader, asset.meshes, streamConfig);
  return r;
}

PreparedPage preparePage(const lod::PageData& data, const lod::PageTable& table, uint32_t mesh, uint32_t page,
                         uint32_t pageBase, uint32_t clusterBase) {
  PreparedPage out;
  out.units = layoutPage(data, nullptr, nullptr);
  std::vector<uint32_t> local(out.units);
  for (uint32_t k = 0; k < out.units; ++k) local[k] = k;
  layoutPage(data, local.data(), &out.packed);
  out.clusterVertices = data.clusterVertices.size();
  size_t n = data.clusterIds.size();
  out.ids.reserve(n), out.records.reserve(n);
  std::vector<glm::vec3> positions;
  for (size_t i = 0; i < n; ++i) {
    const lod::Cluster& c = data.clusters[i];
    positions.resize(c.vertexCount);
    for (uint32_t v = 0; v < c.vertexCount; ++v)
      positions[v] = data.positions[data.clusterVertices[c.vertexOffset + v]];
    std::span<const uint8_t> indices{data.clusterIndices.data() + size_t(c.triangleOffset) * 3,
                                     size_t(c.triangleCount) * 3};
    sio::GpuCluster rec = clusterRecord(c, mesh);
    rec.vertexOffset = out.packed.vertexOffset[i];
    rec.triangleOffset = out.packed.triangleOffset[i];
    rec.maxEdge = clusterMaxEdge(positions, indices);
    rec.cone = clusterCone(positions, indices);
    rec.cluster = clusterBase + data.clusterIds[i];
    rec.page = pageBase + page;
    uint32_t child = table.childPage(c.generatingGroup);
    rec.childPage = child == lod::kNone ? MIRAGE_PAGE_NONE : pageBase + child;
    out.ids.push_back(rec.cluster);
    out.records.push_back(rec);
  }
  return out;
}

void growTrees(LodTrees& trees, const PreparedPage& prep, std::vector<uint32_t>& grown) {
  for (size_t i = 0; i < prep.ids.size(); ++i)
    for (uint32_t tree = 0; tree < 2; ++tree) {
      uint32_t leaf = trees.clusterLeaf[2 * size_t(prep.ids[i]) + tree];
      growLodLeaf(trees, leaf, prep.records[i].selfSphere, grown);
      growLodLeaf(trees, leaf, prep.records[i].boundsSphere, grown);
    }
}

namespace {

// The staging bytes of one frame slot, appended region by region straight into its mapped upload
// buffer (sized for the frame first: stagingBound).
struct StagingBytes {
  uint8_t* base = nullptr;
  size_t size = 0, capacity = 0;
  VkDeviceSize append(const void* data, size_t n) {
    assert(size + n <= capacity);
    std::memcpy(base + size, data, n);
    size += n;
    return VkDeviceSize(size - n);
  }
};

// Units for `page`: `count` from the free stack (the manager's budget guarantees them).
bool takeUnits(ClusterResidency& r, uint32_t page, uint32_t count) {
  if (r.freeUnits.size() < count) return false;
  r.pageUnits[page].assign(r.freeUnits.end() - count, r.freeUnits.end());
  r.freeUnits.resize(r.freeUnits.size() - count);
  return true;
}

void releaseUnits(ClusterResidency& r, uint32_t page, size_t keep = 0) {
  std::vector<uint32_t>& units = r.pageUnits[page];
  r.freeUnits.insert(r.freeUnits.end(), units.begin() + ptrdiff_t(keep), units.end());
  units.resize(keep);
}

// preparePage on this thread (the root pages).
PreparedPage prepareHere(const ClusterResidency& r, uint32_t page, const lod::PageData& data) {
  uint32_t mesh = r.pageMesh[page];
  return preparePage(data, r.asset->meshes[mesh].table, mesh, r.pageLocal[page], r.manager.graph().pageOffset[mesh],
                     r.meshClusterOffset[mesh]);
}

// A reserved page's upload is ready (preparePage, on a reader thread or here): its spare units
// freed, its cost made exact, its vertex ids moved to the units it holds (in its bytes).
Status placePage(ClusterResidency& r, uint32_t page, PreparedPage& prep) {
  uint32_t mesh = r.pageMesh[page];
  const lod::PagedMesh& pm = r.asset->meshes[mesh];
  uint32_t expected = pm.rest.pageClusterVertices[r.pageLocal[page]];
  if (prep.clusterVertices != expected || prep.units > r.pageUnits[page].size())
    return Error{fmt::format("{}: mesh {} page {}: {} vertex ids in {} pool units, the index says {} ids",
                             r.asset->reader->path(), mesh, r.pageLocal[page], prep.clusterVertices, prep.units,
                             expected)};
  releaseUnits(r, page, prep.units);
  r.manager.setPageBytes(page, uint64_t(prep.units) * kPoolUnitBytes);
  const std::vector<uint32_t>& units = r.pageUnits[page];
  // Local to pool: vertex v of the page sits in unit v / kUnitVertices, so its id becomes
  // units[v / kUnitVertices] * kUnitVertices + v % kUnitVertices.
  constexpr uint32_t kUnitVertices = kPoolUnitBytes / sizeof(sio::GpuClusterVertex);
  static_assert(kPoolUnitBytes % sizeof(sio::GpuClusterVertex) == 0, "vertex units hold whole vertices");
  for (const sio::GpuCluster& rec : prep.records) { // the vertex ids, in the page's own bytes
    uint8_t* ids = prep.packed.bytes.data() + size_t(rec.vertexOffset) * 4;
    for (uint32_t j = 0; j < rec.vertexCount; ++j) {
      uint32_t v;
      std::memcpy(&v, ids + 4 * j, 4);
      v = units[v / kUnitVertices] * kUnitVertices + v % kUnitVertices;
      std::memcpy(ids + 4 * j, &v, 4);
    }
  }
  return Ok{};
}

// A placed page's unit bytes staged, each copy to the pool unit it goes to.
void stagePoolBytes(const PreparedPage& prep, const std::vector<uint32_t>& units, StagingBytes& staging,
                    std::vector<VkBufferCopy>& copies) {
  const PagePacking& packed = prep.packed;
  for (uint32_t k = 0; k < packed.unitFill.size(); ++k)
    if (packed.unitFill[k] > 0)
      copies.push_back({staging.append(packed.bytes.data() + size_t(k) * kPoolUnitBytes, packed.unitFill[k]),
                        VkDeviceSize(units[k]) * kPoolUnitBytes, packed.unitFill[k]});
}

// Appends a copy of `size` bytes, joined to the last one where both sides continue it.
void appendCopy(std::vector<VkBufferCopy>& copies, VkDeviceSize src, VkDeviceSize dst, VkDeviceSize size) {
  if (!copies.empty()) {
    VkBufferCopy& last = copies.back();
    if (last.srcOffset + last.size == src && last.dstOffset + last.size == dst) {
      last.size += size;
      return;
    }
  }
  copies.push_back({src, dst, size});
}

// A placed page's records (offsets moved to its units) staged into their slots in its units (one
// copy per run of them); the page is uploaded once the frame's copies run, and its clusters find
// their records once it is drawn (stageClusterSlots).
void stagePageTables(ClusterResidency& r, uint32_t page, const PreparedPage& prep, StagingBytes& staging,
                     ClusterResidency::Slot& slot) {
  const std::vector<uint32_t>& units = r.pageUnits[page];
  auto pooled = [&](uint64_t localByte) { // a local byte offset in the pool
    return uint64_t(units[localByte / kPoolUnitBytes]) * kPoolUnitBytes + localByte % kPoolUnitBytes;
  };
  std::vector<uint32_t>& slots = r.recordSlots[page];
  slots.clear();
  for (size_t i = 0; i < prep.ids.size(); ++i) {
    sio::GpuCluster rec = prep.records[i];
    uint64_t idsByte = uint64_t(rec.vertexOffset) * 4;
    rec.vertexOffset = uint32_t(pooled(idsByte) / 4);
    rec.triangleOffset = uint32_t(pooled(uint64_t(rec.triangleOffset) * 3) / 3);
    uint64_t at = pooled(prep.packed.recordOffset[i]);
    slots.push_back(uint32_t(at / sizeof(rec)));
    appendCopy(slot.records, staging.append(&rec, sizeof(rec)), at, sizeof(rec));
  }
  r.state[page] = PageState::Uploaded;
  r.recordBytes += slots.size() * sizeof(sio::GpuCluster);
  r.geometry[page] = prep.packed.geometryBytes;
  r.geometryBytes += prep.packed.geometryBytes;
}

// The staging bytes of a page's pool bytes (stagePoolBytes).
size_t poolBytes(const PreparedPage& prep) {
  size_t bytes = 0;
  for (uint32_t fill : prep.packed.unitFill) bytes += fill;
  return bytes;
}

// The staging bytes of a page's records (stagePageTables).
size_t tableBytes(const PreparedPage& prep) { return prep.ids.size() * sizeof(sio::GpuCluster); }

// The cluster-slot writes of pages drawn (their records' slots) or no longer drawn (none) this
// frame, into the slot's own staging (sized here, after the manager's step), one copy per run of
// consecutive cluster ids.
void stageClusterSlots(ClusterResidency& r, const std::vector<uint32_t>& drawnNow, const std::vector<uint32_t>& undrawn,
                       ClusterResidency::Slot& slot) {
  std::vector<std::pair<uint32_t, uint32_t>> writes; // (cluster, slot)
  auto add = [&](uint32_t p, bool draw) {
    const std::vector<uint32_t>& slots = r.recordSlots[p];
    std::span<const uint32_t> ids = r.asset->meshes[r.pageMesh[p]].table.clustersOf(r.pageLocal[p]);
    assert(slots.size() == ids.size());
    uint32_t base = r.meshClusterOffset[r.pageMesh[p]];
    for (size_t i = 0; i < ids.size(); ++i) writes.push_back({base + ids[i], draw ? slots[i] : MIRAGE_PAGE_NONE});
  };
  for (uint32_t p : undrawn) add(p, false);
  for (uint32_t p : drawnNow) add(p, true);
  if (writes.empty()) return;
  std::sort(writes.begin(), writes.end());
  size_t bytes = writes.size() * 4;
  if (!slot.slotStaging || slot.slotStaging.size() < bytes) // this slot's last frame completed
    slot.slotStaging = createBuffer(*r.ctx, std::max<size_t>(bytes, slot.slotStaging ? slot.slotStaging.size() * 2 : 0),
                                    VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "residency slot staging");
  StagingBytes staging{slot.slotStaging.mapped(), 0, slot.slotStaging.size()};
  for (auto [cluster, value] : writes)
    appendCopy(slot.clusterSlots, staging.append(&value, 4), VkDeviceSize(cluster) * 4, 4);
}

using TransferBatch = ClusterResidency::TransferBatch;

// A batch entry's page still waits for it: not evicted, not staged again since, the same units.
bool waitsFor(const ClusterResidency& r, const TransferBatch::Entry& entry) {
  return r.state[entry.page] == PageState::Reserved && r.pageUnits[entry.page] == entry.units;
}

// Frees the batches the slot's last frame copied from (it completed: the slot is being reused);
// then takes in every batch the transfer queue finished (a fence check, no wait). Returns the
// table bytes their waiting pages will stage (the slot's staging is sized first).
size_t arrivedBatches(ClusterResidency& r, uint32_t slotIndex, std::vector<TransferBatch*>& arrived) {
  size_t bytes = 0;
  for (uint32_t b = 0; b < r.batches.size(); ++b) {
    TransferBatch& batch = *r.batches[b];
    if (batch.state == TransferBatch::State::Consumed && batch.slot == slotIndex)
      batch.state = TransferBatch::State::Free;
    if (batch.state != TransferBatch::State::Copying) continue;
    VkFence done = batch.done.get();
    if (vkWaitForFences(r.ctx->device(), 1, &done, VK_TRUE, 0) != VK_SUCCESS) continue;
    MIRAGE_VK_CHECK(vkResetFences(r.ctx->device(), 1, &done));
    r.ctx->freeOneShot(std::exchange(batch.cmd, VK_NULL_HANDLE));
    batch.state = TransferBatch::State::Consumed;
    batch.slot = slotIndex;
    for (TransferBatch::Entry& entry : batch.entries) {
      if (r.transit[entry.page] != b + 1) { // staged again since (a later batch has it)
        entry.units.clear();
        continue;
      }
      r.transit[entry.page] = 0;
      if (waitsFor(r, entry)) bytes += tableBytes(entry.prep);
    }
    arrived.push_back(&batch);
  }
  return bytes;
}

// The waiting pages of an arrived batch: copies from its device buffer, tables staged, uploaded.
uint32_t uploadArrived(ClusterResidency& r, TransferBatch& batch, StagingBytes& staging, ClusterResidency::Slot& slot) {
  uint32_t uploaded = 0;
  std::vector<VkBufferCopy> copies;
  for (TransferBatch::Entry& entry : batch.entries) {
    if (entry.units.empty() || !waitsFor(r, entry)) continue;
    copies.insert(copies.end(), entry.pool.begin(), entry.pool.end());
    stagePageTables(r, entry.page, entry.prep, staging, slot);
    ++uploaded;
  }
  if (!copies.empty()) slot.fromDevice.push_back({&batch.device, std::move(copies)});
  batch.entries.clear();
  return uploaded;
}

// Placed pages' pool bytes in a free batch (made or grown as needed), sent on the transfer queue;
// their tables wait for the batch to arrive.
void sendBatch(ClusterResidency& r, std::vector<std::pair<uint32_t, PreparedPage*>>& pages) {
  size_t bytes = 0;
  for (auto& [p, prep] : pages) bytes += poolBytes(*prep);
  uint32_t b = 0;
  while (b < r.batches.size() && r.batches[b]->state != TransferBatch::State::Free) ++b;
  if (b == r.batches.size()) {
    auto batch = std::make_unique<TransferBatch>();
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence;
    MIRAGE_VK_CHECK(vkCreateFence(r.ctx->device(), &fi, nullptr, &fence));
    batch->done = gpu::Unique<VkFence>(r.ctx->device(), fence);
    r.batches.push_back(std::move(batch));
  }
  TransferBatch& batch = *r.batches[b];
  if (!batch.host || batch.host.size() < bytes) {
    size_t size = std::max<size_t>(bytes, batch.host ? batch.host.size() * 2 : 0);
    batch.host =
        createBuffer(*r.ctx, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "residency transfer staging");
    batch.device = createBuffer(*r.ctx, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                MemoryUsage::GpuOnly, "residency transfer pages", /*withTransferQueue=*/true);
  }
  StagingBytes staging{batch.host.mapped(), 0, batch.host.size()};
  for (auto& [p, prep] : pages) {
    TransferBatch::Entry& entry = batch.entries.emplace_back();
    entry.page = p;
    entry.units = r.pageUnits[p];
    stagePoolBytes(*prep, entry.units, staging, entry.pool);
    entry.prep = std::move(*prep);
    entry.prep.packed.bytes = {}; // on their way
    r.transit[p] = b + 1;
  }
  batch.cmd = r.ctx->beginTransferCommands();
  VkBufferCopy all{0, 0, std::max<VkDeviceSize>(staging.size, 4)};
  vkCmdCopyBuffer(batch.cmd, batch.host.handle(), batch.device.handle(), 1, &all);
  r.ctx->submitTransfer(batch.cmd, batch.done.get());
  batch.state = TransferBatch::State::Copying;
}

} // namespace

void ClusterResidency::waitForTransfers() const {
  for (const std::unique_ptr<TransferBatch>& b : batches)
    if (b->state == TransferBatch::State::Copying) {
      VkFence done = b->done.get();
      vkWaitForFences(ctx->device(), 1, &done, VK_TRUE, UINT64_MAX);
    }
}

ClusterResidency::~ClusterResidency() {
  for (const std::unique_ptr<TransferBatch>& b : batches)
    if (b->cmd) {
      VkFence done = b->done.get();
      vkWaitForFences(ctx->device(), 1, &done, VK_TRUE, UINT64_MAX);
      ctx->freeOneShot(b->cmd);
    }
}

namespace {

// The view's prefetch (lod::prefetchFeedback) of every instance, numbered as one; the selection's
// projection in each instance's object space (exact for uniform scales, the eye and near distance
// divided out), the frustum's side and near planes carried there.
void computePrefetch(ClusterResidency& r, const sio::ViewFrame& v, float tau) {
  r.prefetchHost.assign(r.pageMesh.size(), 0.0f);
  for (const Instance& inst : r.instances) {
    if (inst.mesh >= r.asset->meshes.size()) continue;
    float scale = maxAxisScale(inst.transform);
    if (!(scale > 0.0f)) continue;
    glm::vec4 sphere = r.meshReach[inst.mesh];
    glm::vec3 centre(inst.transform * glm::vec4(glm::vec3(sphere), 1.0f));
    bool outside = false;
    for (const glm::vec4& plane : v.planes)
      outside = outside || glm::dot(plane, glm::vec4(centre, 1.0f)) < -sphere.w * scale;
    if (outside) continue; // no group of it in view
    glm::mat4 toObject = glm::inverse(inst.transform);
    lod::CutView cv;
    cv.eye = glm::vec3(toObject * glm::vec4(glm::vec3(v.eye), 1.0f));
    cv.znear = v.znear / scale;
    cv.pixelScale = v.pixelScale;
    cv.tau = tau;
    glm::vec4 planes[5];
    for (int i = 0; i < 5; ++i) planes[i] = glm::transpose(inst.transform) * v.planes[i];
    std::vector<float> wanted = lod::prefetchFeedback(r.asset->meshes[inst.mesh].table, cv, planes, scale);
    lod::mergeFeedback(r.prefetchHost, wanted, r.manager.graph().pageOffset[inst.mesh]);
  }
}

} // namespace

// Arrived pages are uploaded, the manager acts on the last collected feedback (its loads reserve
// units and queue reads, its evictions free units), and pages whose dependencies are drawn are
// drawn from this frame on. Nothing here waits for I/O.
Status ClusterRenderer::Impl::prepareResidency(const ClusterRenderSettings& cs) {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[currentSlot];
  for (auto* v : {&slot.pool, &slot.records, &slot.table, &slot.nodes, &slot.clusterSlots}) v->clear();
  slot.fromDevice.clear();
  slot.stats = {};
  ResidencyStats& st = slot.stats;
  ResidencyTimes& times = st.times;
  PhaseClock clock;
  auto arrived = r.stream->take();
  if (!arrived) return arrived.error();
  times.takeMs += clock.lap();
  // This frame's uploads: (1) the root pages, resident since creation, in the first frame; (2) the
  // pages read since the last frame if still reserved (an evicted one is dropped). The staging
  // buffer is sized for them and the drawn-page table first, then written in place.
  std::deque<PreparedPage> preparedHere; // pages the stream did not prepare (the roots)
  std::vector<std::pair<uint32_t, PreparedPage*>> uploads;
  size_t roots = 0; // the first `roots` of `uploads`
  if (!r.rootsStaged) {
    r.rootsStaged = true;
    for (uint32_t p = 0; p < r.pageMesh.size(); ++p) {
      if (!r.manager.isResident(p)) continue;
      uint32_t units = uint32_t(r.manager.graph().bytes[p] / kPoolUnitBytes);
      if (!takeUnits(r, p, units)) return Error{"residency: the root pages do not fit the pool"};
      r.state[p] = PageState::Reserved;
      preparedHere.push_back(prepareHere(r, p, r.asset->rootPages[r.pageMesh[p]][r.pageLocal[p]]));
      uploads.push_back({p, &preparedHere.back()});
    }
    roots = uploads.size();
  }
  for (lod::StreamedPage& a : *arrived) {
    times.decodeMs += a.seconds * 1e3;
    times.layoutMs += a.prepareSeconds * 1e3;
    uint32_t p = r.manager.graph().pageOffset[a.mesh] + a.page;
    r.reading[p] = 0;
    if (r.state[p] != PageState::Reserved) continue;
    PreparedPage* prep = std::any_cast<PreparedPage>(&a.prepared);
    if (!prep) prep = &preparedHere.emplace_back(prepareHere(r, p, a.data));
    uploads.push_back({p, prep});
  }
  // The trees' bounds grow by the arriving pages' spheres (their nodes staged below; bounds only
  // grow, so growing them before a page's bytes reach the pool is safe).
  std::vector<uint32_t> grown;
  for (auto& [p, prep] : uploads) growTrees(r.trees, *prep, grown);
  std::sort(grown.begin(), grown.end());
  grown.erase(std::unique(grown.begin(), grown.end()), grown.end());
  // Placed first (spare units freed, vertex ids moved to the units held). With transfer uploads
  // the streamed pages go on the transfer queue now and reach the pool in a later frame (the roots
  // go in this frame, so the first frame draws the whole scene); the batches that arrived since the
  // last frame are taken in first, so a page is never both sent and taken in by one frame.
  for (auto& [p, prep] : uploads)
    if (Status s = placePage(r, p, *prep); !s) return s;
  std::vector<std::pair<uint32_t, PreparedPage*>> sent;
  if (r.transferUploads) {
    sent.assign(uploads.begin() + ptrdiff_t(roots), uploads.end());
    uploads.resize(roots);
  }
  std::vector<TransferBatch*> batchesIn;
  size_t bound = r.drawn.size() * 4 + grown.size() * sizeof(sio::GpuLodNode);
  if (r.transferUploads) bound += arrivedBatches(r, currentSlot, batchesIn);
  if (!sent.empty()) sendBatch(r, sent);
  for (auto& [p, prep] : uploads) bound += tableBytes(*prep) + poolBytes(*prep);
  if (!slot.staging || slot.staging.size() < bound) // this slot's last frame completed
    slot.staging = createBuffer(ctx, std::max<size_t>(bound, slot.staging ? slot.staging.size() * 2 : 0),
                                VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "residency staging");
  StagingBytes staging{slot.staging.mapped(), 0, slot.staging.size()};
  for (TransferBatch* batch : batchesIn) st.uploaded += uploadArrived(r, *batch, staging, slot);
  for (auto& [p, prep] : uploads) {
    stagePoolBytes(*prep, r.pageUnits[p], staging, slot.pool);
    stagePageTables(r, p, *prep, staging, slot);
    ++st.uploaded;
  }
  for (uint32_t n : grown)
    slot.nodes.push_back({staging.append(&r.trees.nodes[n], sizeof(sio::GpuLodNode)),
                          VkDeviceSize(n) * sizeof(sio::GpuLodNode), sizeof(sio::GpuLodNode)});
  times.uploadMs += clock.lap();
  // (3) The manager's step: evictions free units and stop drawing; loads reserve units and queue reads.
  r.cutPending = r.cutPending || cs.cameraCut;
  if (r.haveFeedback && r.prefetch) {
    // Computed again only on a cut (or a new size or tau): between cuts the feedback follows the
    // camera's small steps, and the last prefetch (a view close to this one) still joins it.
    glm::vec3 target(float(cs.base.width), float(cs.base.height), cs.tauPixels);
    if (r.prefetchHost.empty() || r.cutPending || target != r.prefetchTarget ||
        isCameraCut(r.prefetchCamera, cs.base.camera, scene.worldBounds)) {
      times.stepMs += clock.lap();
      sio::ViewFrame v = viewFrame(withClipPlanes(cs.base.camera, scene.worldBounds), cs.base.width, cs.base.height);
      computePrefetch(r, v, cs.tauPixels);
      r.prefetchCamera = cs.base.camera;
      r.prefetchTarget = target;
      r.cutPending = false;
      st.prefetched = true;
      times.prefetchMs += clock.lap();
    }
    lod::mergeFeedback(r.feedbackHost, r.prefetchHost);
  }
  std::vector<uint32_t> undrawn, drawnNow; // pages whose clusters' slots change this frame
  std::vector<uint32_t> evicted;
  if (r.haveFeedback) {
    lod::ResidencyStep step = r.manager.step(r.feedbackHost);
    r.haveFeedback = false;
    st.stepped = true;
    for (uint32_t p : step.evicted) {
      if (r.state[p] == PageState::Uploaded) {
        r.geometryBytes -= r.geometry[p];
        r.recordBytes -= r.recordSlots[p].size() * sizeof(sio::GpuCluster);
      }
      if (r.drawn[p] != MIRAGE_PAGE_NONE) undrawn.push_back(p);
      r.state[p] = PageState::Absent;
      r.drawn[p] = MIRAGE_PAGE_NONE;
      releaseUnits(r, p);
    }
    for (uint32_t p : step.loaded) {
      uint32_t units = uint32_t(r.manager.graph().bytes[p] / kPoolUnitBytes);
      if (!takeUnits(r, p, units)) return Error{"residency: no free pool units (the manager exceeded the pool)"};
      r.state[p] = PageState::Reserved;
      r.toRead.push_back(p);
    }
    evicted = std::move(step.evicted);
    st.loaded = uint32_t(step.loaded.size());
    st.evicted = uint32_t(evicted.size());
    st.unfit = step.unfit;
  }
  times.stepMs += clock.lap();
  // (4) Reads, as far as the stream has room (pages evicted before their read are skipped).
  while (!r.toRead.empty()) {
    uint32_t p = r.toRead.front();
    if (r.state[p] == PageState::Reserved && !r.reading[p]) {
      if (!r.stream->request(r.pageMesh[p], r.pageLocal[p])) break;
      r.reading[p] = 1;
    }
    r.toRead.pop_front();
  }
  times.requestMs += clock.lap();
  // (5) Drawn: uploaded pages whose dependencies are drawn (a mesh's dependencies come before
  // it in page order, so one ascending pass settles every chain).
  bool tableChanged = st.evicted > 0;
  for (uint32_t p = 0; p < r.pageMesh.size(); ++p) {
    if (r.state[p] != PageState::Uploaded || r.drawn[p] != MIRAGE_PAGE_NONE) continue;
    bool ready = true;
    for (uint32_t d : r.manager.graph().dependenciesOf(p)) ready = ready && r.drawn[d] != MIRAGE_PAGE_NONE;
    if (!ready) continue;
    r.drawn[p] = r.pageUnits[p].front();
    drawnNow.push_back(p);
    tableChanged = true;
  }
  if (tableChanged) slot.table.push_back({staging.append(r.drawn.data(), r.drawn.size() * 4), 0, r.drawn.size() * 4});
  stageClusterSlots(r, drawnNow, undrawn, slot);
  for (uint32_t p : evicted) r.recordSlots[p] = {};
  slot.resident.resize(r.drawn.size());
  for (size_t p = 0; p < r.drawn.size(); ++p) slot.resident[p] = r.drawn[p] != MIRAGE_PAGE_NONE;
  st.enabled = true;
  st.budgetBytes = r.budgetBytes;
  st.unitBytes = kPoolUnitBytes;
  st.units = r.units;
  st.poolBytes = uint64_t(r.units) * kPoolUnitBytes + MIRAGE_CLUSTER_MAX_TRIANGLES * 3;
  st.pages = uint32_t(r.pageMesh.size());
  st.residentPages = r.manager.residentPages();
  st.residentBytes = r.manager.residentBytes();
  st.geometryBytes = r.geometryBytes;
  st.recordBytes = r.recordBytes;
  st.clusterTableBytes =
      r.clusterSlots.size() + scene.leafClusters.size() + (scene.clusters ? scene.clusters.size() : 0);
  st.treeNodeBytes = scene.lodNodes.size();
  st.clusters = scene.clusterCount;
  st.bytesRead = r.stream->storedBytes();
  st.bytesReceived = r.stream->receivedBytes();
  for (uint32_t p = 0; p < r.pageMesh.size(); ++p) {
    st.drawnPages += r.drawn[p] != MIRAGE_PAGE_NONE;
    st.pending += r.state[p] == PageState::Reserved;
    st.inTransit += r.state[p] == PageState::Reserved && r.transit[p] != 0;
  }
  times.publishMs += clock.lap();
  return Ok{};
}

// After the frame's first barrier (every earlier frame's reads of the pool are done): the uploads,
// then a cleared feedback; the caller's phase barrier makes both visible to the selection.
void ClusterRenderer::Impl::cmdResidencyUpload(VkCommandBuffer cmd) {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[currentSlot];
  if (r.poolUnzeroed) {
    vkCmdFillBuffer(cmd, scene.vertices.handle(), 0, VK_WHOLE_SIZE, 0);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    r.poolUnzeroed = false;
  }
  auto copy = [&](const std::vector<VkBufferCopy>& regions, const Buffer& dst) {
    if (!regions.empty())
      vkCmdCopyBuffer(cmd, slot.staging.handle(), dst.handle(), uint32_t(regions.size()), regions.data());
  };
  copy(slot.pool, scene.vertices);
  for (const auto& [from, regions] : slot.fromDevice) // transfer uploads that arrived (fence seen)
    vkCmdCopyBuffer(cmd, from->handle(), scene.vertices.handle(), uint32_t(regions.size()), regions.data());
  copy(slot.records, scene.vertices); // beside the geometry, in the pages' units
  copy(slot.table, r.pageSlots);
  copy(slot.nodes, scene.lodNodes);
  if (!slot.clusterSlots.empty())
    vkCmdCopyBuffer(cmd, slot.slotStaging.handle(), r.clusterSlots.handle(), uint32_t(slot.clusterSlots.size()),
                    slot.clusterSlots.data());
  vkCmdFillBuffer(cmd, r.feedback.handle(), 0, VK_WHOLE_SIZE, 0);
  // The lists' entry 0, which lanes of background pixels load (cluster_resolve.comp), names a
  // record of this frame whatever the selection appends: the first record of page 0, a root page
  // (never evicted, its records never move).
  assert(!r.recordSlots[0].empty()); // root pages are staged and drawn in the first frame
  sio::VisibleCluster valid{0, r.recordSlots[0].front()};
  vkCmdUpdateBuffer(cmd, visible.handle(), 0, sizeof(valid), &valid);
  if (blendVisible) vkCmdUpdateBuffer(cmd, blendVisible.handle(), 0, sizeof(valid), &valid);
}

// In finishFrame, before its host barrier: the feedback into this slot's readback.
void ClusterRenderer::Impl::cmdResidencyFeedback(VkCommandBuffer cmd) {
  ClusterResidency& r = *residency;
  VkBufferCopy region{0, 0, r.feedback.size()};
  vkCmdCopyBuffer(cmd, r.feedback.handle(), r.frame[currentSlot].readback.handle(), 1, &region);
}

void ClusterRenderer::Impl::packResidency(sio::ClusterFrame& f) const {
  f.flags |= MIRAGE_FRAME_RESIDENCY;
  f.clusterSlotAddress = residency->clusterSlots.address();
  f.pageSlotAddress = residency->pageSlots.address();
  f.pageFeedbackAddress = residency->feedback.address();
}

// The slot's feedback becomes the next recorded frame's input (frames are collected in order:
// the last collected is the newest).
ResidencyStats ClusterRenderer::Impl::collectResidency(uint32_t frameSlot) {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[frameSlot];
  PhaseClock clock;
  uint32_t pages = uint32_t(r.pageMesh.size());
  r.feedbackHost.resize(pages);
  std::memcpy(r.feedbackHost.data(), slot.readback.mapped(), pages * 4ull);
  r.haveFeedback = true;
  ResidencyStats st = slot.stats;
  for (uint32_t p = 0; p < pages; ++p) st.requested += r.feedbackHost[p] > 0.0f && !slot.resident[p];
  st.times.collectMs += clock.lap();
  return st;
}

std::unordered_map<uint32_t, uint32_t> drawnSlotClusters(const ClusterResidency& r) {
  std::unordered_map<uint32_t, uint32_t> out;
  for (uint32_t p = 0; p < r.drawn.size(); ++p) {
    if (r.drawn[p] == MIRAGE_PAGE_NONE) continue;
    std::span<const uint32_t> ids = r.asset->meshes[r.pageMesh[p]].table.clustersOf(r.pageLocal[p]);
    for (size_t i = 0; i < ids.size(); ++i) out[r.recordSlots[p][i]] = r.meshClusterOffset[r.pageMesh[p]] + ids[i];
  }
  return out;
}

bool ClusterRenderer::hasResidency() const { return impl_->residency != nullptr; }

Result<ClusterRenderer::Converged> ClusterRenderer::renderConverged(const ClusterRenderSettings& settings,
                                                                    uint32_t maxFrames, bool readEveryFrame) {
  Converged out;
  if (!impl_->residency) {
    auto o = render(settings);
    if (!o) return o.error();
    out.output = std::move(*o);
    out.converged = true;
    return out;
  }
  ClusterRenderSettings quiet = settings;
  quiet.base.readImage = readEveryFrame && settings.base.readImage;
  quiet.base.readLinear = false;
  quiet.readOwnedClusters = false;
  double waitedMs = 0; // waiting for a read before the next frame: that frame's
  for (uint32_t frame = 0; frame < maxFrames; ++frame) {
    auto o = render(quiet);
    if (!o) return o.error();
    o->stats.residency.times.readWaitMs += std::exchange(waitedMs, 0.0);
    out.frameEnds.push_back(std::chrono::steady_clock::now());
    out.frameGpuMs.push_back(gpu::passMilliseconds(o->image.stats.passTimes, "frame"));
    if (quiet.base.readImage) out.frameImages.push_back(std::move(o->image.srgb));
    quiet.cameraCut = false; // the cut is this call's first frame only
    const ResidencyStats& st = o->stats.residency;
    out.frames.push_back(st);
    // The first frame steps on the feedback of whatever was drawn before (another camera, say):
    // only a later frame, stepping on this view's feedback, can tell that the view is complete.
    bool quietFrame = frame > 0 && st.stepped && st.loaded == 0 && st.uploaded == 0 && st.evicted == 0;
    if (quietFrame && st.pending == 0) {
      out.framesToConverge = frame;
      out.converged = true;
      break;
    }
    // Only waiting for reads or transfers: wait for the next page (or batch) instead of spinning.
    if (quietFrame) {
      PhaseClock clock;
      if (st.inTransit > 0)
        impl_->residency->waitForTransfers();
      else
        impl_->residency->stream->waitForArrival(std::chrono::milliseconds(1000));
      waitedMs = clock.lap();
    }
  }
  if (!out.converged) out.framesToConverge = maxFrames;
  ClusterRenderSettings last = settings; // the stable residency again, read back as asked
  last.cameraCut = false;
  auto o = render(last);
  if (!o) return o.error();
  out.frameEnds.push_back(std::chrono::steady_clock::now());
  out.frameGpuMs.push_back(gpu::passMilliseconds(o->image.stats.passTimes, "frame"));
  out.frames.push_back(o->stats.residency);
  if (quiet.base.readImage) out.frameImages.push_back(o->image.srgb);
  out.output = std::move(*o);
  return out;
}

} // namespace mirage::render
