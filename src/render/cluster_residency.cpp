// GPU residency of paged DAGs (docs/render.md, "Residency"): the page pool and its tables, the
// uploads each frame records, the feedback each frame reads back, and the manager between them.
#include "cluster_residency.h"

#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/shaderio/lod_paging.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

Result<std::unique_ptr<ClusterResidency>> createClusterResidency(Context& ctx, const lod::LodAsset& asset,
                                                                 const ClusterResidencySettings& settings,
                                                                 ClusterSceneData& scene,
                                                                 std::vector<sio::GpuCluster> records) {
  const std::string& file = asset.scene.source;
  if (settings.tables.size() != asset.dags.size())
    return Error{fmt::format("{}: --gpu-budget needs a paged asset (mirage build --paged): {} page tables for {} "
                             "meshes",
                             file, settings.tables.size(), asset.dags.size())};
  if (!settings.pages) return Error{file + ": residency without a page source"};
  // Slot sizes: the largest page's vertices, vertex ids (its clusters' vertex counts) and triangles.
  uint32_t slotVertices = 1, slotClusterVertices = 1, slotTriangles = 4;
  std::vector<uint32_t> pageMesh, pageLocal, meshClusterOffset;
  uint32_t clusterBase = 0;
  for (uint32_t m = 0; m < asset.dags.size(); ++m) {
    const lod::PageTable& t = *settings.tables[m];
    const lod::ClusterDag& dag = asset.dags[m];
    if (t.clusterPage.size() != dag.clusters.size())
      return Error{fmt::format("{}: mesh {}: page table of {} clusters for a DAG of {}", file, m, t.clusterPage.size(),
                               dag.clusters.size())};
    meshClusterOffset.push_back(clusterBase);
    clusterBase += uint32_t(dag.clusters.size());
    for (uint32_t p = 0; p < t.pages.size(); ++p) {
      uint32_t ids = 0;
      for (uint32_t c : t.clustersOf(p)) ids += dag.clusters[c].vertexCount;
      slotVertices = std::max(slotVertices, t.pages[p].vertexCount);
      slotClusterVertices = std::max(slotClusterVertices, ids);
      slotTriangles = std::max(slotTriangles, (t.pages[p].triangleCount + 3) / 4 * 4);
      pageMesh.push_back(m);
      pageLocal.push_back(p);
    }
  }
  uint64_t slotBytes =
      uint64_t(slotVertices) * sizeof(sio::GpuClusterVertex) + uint64_t(slotClusterVertices) * 4 + slotTriangles * 3ull;
  lod::ResidencyGraph graph = lod::residencyGraph(std::span<const lod::PageTable* const>(settings.tables),
                                                  [&](uint32_t, uint32_t) { return slotBytes; });
  lod::ResidencyConfig config{settings.budgetBytes, std::max(settings.maxUploadsPerFrame, 1u)};
  auto manager = lod::ResidencyManager::create(std::move(graph), config);
  if (!manager)
    return Error{
        fmt::format("{}: --gpu-budget: {} (pages take slots of {} bytes)", file, manager.error().message, slotBytes)};
  auto r = std::make_unique<ClusterResidency>(std::move(*manager));
  r->source = settings.pages;
  r->pageMesh = std::move(pageMesh);
  r->pageLocal = std::move(pageLocal);
  r->meshClusterOffset = std::move(meshClusterOffset);
  r->slotVertices = slotVertices, r->slotClusterVertices = slotClusterVertices, r->slotTriangles = slotTriangles;
  r->slotBytes = slotBytes;
  r->budgetBytes = settings.budgetBytes;
  r->slots = uint32_t(std::min<uint64_t>(settings.budgetBytes / slotBytes, r->pageMesh.size()));
  uint32_t pages = uint32_t(r->pageMesh.size());
  r->pageSlot.assign(pages, MIRAGE_PAGE_NONE);
  for (uint32_t s = r->slots; s-- > 0;) r->freeSlots.push_back(s);
  r->records = std::move(records);

  // Per cluster: (page, child page), numbered over every mesh.
  std::vector<uint32_t> clusterPages;
  clusterPages.reserve(r->records.size() * 2);
  for (uint32_t m = 0; m < asset.dags.size(); ++m) {
    const lod::PageTable& t = *settings.tables[m];
    uint32_t base = r->manager.graph().pageOffset[m];
    for (const lod::Cluster& c : asset.dags[m].clusters) {
      uint32_t child = t.childPage(c.generatingGroup);
      clusterPages.push_back(base + t.clusterPage[&c - asset.dags[m].clusters.data()]);
      clusterPages.push_back(child == lod::kNone ? MIRAGE_PAGE_NONE : base + child);
    }
  }
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  constexpr VkBufferUsageFlags kCopied = kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  r->clusterPages = createBufferWithData<uint32_t>(ctx, clusterPages, kStorage, "residency cluster pages");
  r->pageSlots = createBufferWithData<uint32_t>(ctx, r->pageSlot, kStorage, "residency page slots");
  r->feedback = createBuffer(ctx, pages * 4ull, kCopied, MemoryUsage::GpuOnly, "residency feedback");
  for (ClusterResidency::Slot& s : r->frame)
    s.readback = createBuffer(ctx, pages * 4ull, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback,
                              "residency feedback readback");
  // The pool takes the place of the scene's geometry: the push constants name it as they would.
  scene.vertices = createBuffer(ctx, std::max<uint64_t>(r->slots, 1) * slotVertices * sizeof(sio::GpuClusterVertex),
                                kCopied, MemoryUsage::GpuOnly, "residency pool vertices");
  scene.clusterVertices = createBuffer(ctx, std::max<uint64_t>(r->slots, 1) * slotClusterVertices * 4ull, kCopied,
                                       MemoryUsage::GpuOnly, "residency pool vertex ids");
  // Padding of one full cluster past the last slot, as uploadClusterScene pads the index array.
  scene.indices =
      createBuffer(ctx, (std::max<uint64_t>(r->slots, 1) * slotTriangles + MIRAGE_CLUSTER_MAX_TRIANGLES) * 3, kCopied,
                   MemoryUsage::GpuOnly, "residency pool indices");
  return r;
}

// The manager acts on the last collected feedback; its uploads are staged for this slot's frame.
Status ClusterRenderer::Impl::prepareResidency() {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[currentSlot];
  for (auto* v : {&slot.vertices, &slot.clusterVertices, &slot.indices, &slot.records, &slot.table}) v->clear();
  slot.stats = {};
  lod::ResidencyStep step;
  bool first = !r.rootsStaged;
  r.rootsStaged = true;
  if (r.haveFeedback) {
    step = r.manager.step(r.feedbackHost);
    r.haveFeedback = false;
    slot.stats.stepped = true;
  } else if (first) {
    // The first frame uploads the root pages the manager made resident at creation.
    for (uint32_t p = 0; p < r.pageMesh.size(); ++p)
      if (r.manager.isResident(p)) step.loaded.push_back(p);
  }
  for (uint32_t p : step.evicted) {
    r.freeSlots.push_back(r.pageSlot[p]);
    r.pageSlot[p] = MIRAGE_PAGE_NONE;
  }
  // Staging: per page its vertices, vertex ids and index words, then every record and the table.
  std::vector<uint8_t> bytes;
  auto append = [&](const void* data, size_t size) {
    size_t at = bytes.size();
    bytes.resize(at + size);
    std::memcpy(bytes.data() + at, data, size);
    return VkDeviceSize(at);
  };
  for (uint32_t p : step.loaded) {
    uint32_t mesh = r.pageMesh[p];
    auto page = r.source(mesh, r.pageLocal[p]);
    if (!page) return page.error();
    if (r.freeSlots.empty()) return Error{"residency: no free page slot (the manager exceeded the pool)"};
    uint32_t s = r.freeSlots.back();
    r.freeSlots.pop_back();
    r.pageSlot[p] = s;
    std::vector<sio::GpuClusterVertex> vertices(page->positions.size());
    for (size_t v = 0; v < vertices.size(); ++v) {
      vertices[v].position = page->positions[v];
      vertices[v].normal = v < page->normals.size() ? page->normals[v] : glm::vec3(0, 1, 0);
      vertices[v].uv = v < page->uv0.size() ? page->uv0[v] : glm::vec2(0.0f);
    }
    uint32_t vertexBase = s * r.slotVertices, idBase = s * r.slotClusterVertices, triangleBase = s * r.slotTriangles;
    std::vector<uint32_t> ids(page->clusterVertices.size());
    for (size_t i = 0; i < ids.size(); ++i) ids[i] = vertexBase + page->clusterVertices[i];
    std::vector<uint32_t> words((page->clusterIndices.size() + 3) / 4, 0u);
    for (size_t i = 0; i < page->clusterIndices.size(); ++i)
      words[i / 4] |= uint32_t(page->clusterIndices[i]) << (8 * (i % 4));
    if (vertices.size() > r.slotVertices || ids.size() > r.slotClusterVertices ||
        page->clusterIndices.size() > r.slotTriangles * 3ull)
      return Error{fmt::format("residency: page {} of mesh {} is larger than its table says", r.pageLocal[p], mesh)};
    slot.vertices.push_back({append(vertices.data(), vertices.size() * sizeof(vertices[0])),
                             VkDeviceSize(vertexBase) * sizeof(sio::GpuClusterVertex),
                             vertices.size() * sizeof(vertices[0])});
    slot.clusterVertices.push_back({append(ids.data(), ids.size() * 4), VkDeviceSize(idBase) * 4, ids.size() * 4});
    if (!words.empty())
      slot.indices.push_back(
          {append(words.data(), words.size() * 4), VkDeviceSize(triangleBase) * 3, words.size() * 4});
    for (size_t i = 0; i < page->clusterIds.size(); ++i) {
      uint32_t g = r.meshClusterOffset[mesh] + page->clusterIds[i];
      sio::GpuCluster& rec = r.records[g];
      rec.vertexOffset = idBase + page->clusters[i].vertexOffset;
      rec.triangleOffset = triangleBase + page->clusters[i].triangleOffset;
      slot.records.push_back({append(&rec, sizeof(rec)), VkDeviceSize(g) * sizeof(rec), sizeof(rec)});
    }
  }
  if (!step.loaded.empty() || !step.evicted.empty())
    slot.table.push_back({append(r.pageSlot.data(), r.pageSlot.size() * 4), 0, r.pageSlot.size() * 4});
  if (!bytes.empty()) {
    if (!slot.staging || slot.staging.size() < bytes.size()) // this slot's last frame completed
      slot.staging = createBuffer(ctx, std::max<size_t>(bytes.size(), slot.staging ? slot.staging.size() * 2 : 0),
                                  VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "residency staging");
    std::memcpy(slot.staging.mapped(), bytes.data(), bytes.size());
  }
  slot.resident.assign(r.manager.resident().begin(), r.manager.resident().end());
  ResidencyStats& st = slot.stats;
  st.enabled = true;
  st.budgetBytes = r.budgetBytes;
  st.slotBytes = r.slotBytes;
  st.slots = r.slots;
  st.poolBytes = uint64_t(r.slots) * r.slotBytes + MIRAGE_CLUSTER_MAX_TRIANGLES * 3;
  st.pages = uint32_t(r.pageMesh.size());
  st.residentPages = r.manager.residentPages();
  st.residentBytes = r.manager.residentBytes();
  st.uploaded = uint32_t(step.loaded.size()); // the first frame: the root pages
  st.evicted = uint32_t(step.evicted.size());
  st.unfit = step.unfit;
  return Ok{};
}

// After the frame's first barrier (every earlier frame's reads of the pool are done): the uploads,
// then a cleared feedback; the caller's phase barrier makes both visible to the selection.
void ClusterRenderer::Impl::cmdResidencyUpload(VkCommandBuffer cmd) {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[currentSlot];
  if (r.poolUnzeroed) {
    for (const Buffer* b : {&scene.vertices, &scene.clusterVertices, &scene.indices})
      vkCmdFillBuffer(cmd, b->handle(), 0, VK_WHOLE_SIZE, 0);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    r.poolUnzeroed = false;
  }
  auto copy = [&](const std::vector<VkBufferCopy>& regions, const Buffer& dst) {
    if (!regions.empty())
      vkCmdCopyBuffer(cmd, slot.staging.handle(), dst.handle(), uint32_t(regions.size()), regions.data());
  };
  copy(slot.vertices, scene.vertices);
  copy(slot.clusterVertices, scene.clusterVertices);
  copy(slot.indices, scene.indices);
  copy(slot.records, scene.clusters);
  copy(slot.table, r.pageSlots);
  vkCmdFillBuffer(cmd, r.feedback.handle(), 0, VK_WHOLE_SIZE, 0);
}

// In finishFrame, before its host barrier: the feedback into this slot's readback.
void ClusterRenderer::Impl::cmdResidencyFeedback(VkCommandBuffer cmd) {
  ClusterResidency& r = *residency;
  VkBufferCopy region{0, 0, r.feedback.size()};
  vkCmdCopyBuffer(cmd, r.feedback.handle(), r.frame[currentSlot].readback.handle(), 1, &region);
}

void ClusterRenderer::Impl::packResidency(sio::ClusterFrame& f) const {
  f.flags |= MIRAGE_FRAME_RESIDENCY;
  f.clusterPageAddress = residency->clusterPages.address();
  f.pageSlotAddress = residency->pageSlots.address();
  f.pageFeedbackAddress = residency->feedback.address();
}

// The slot's feedback becomes the next recorded frame's input (frames are collected in order:
// the last collected is the newest).
ResidencyStats ClusterRenderer::Impl::collectResidency(uint32_t frameSlot) {
  ClusterResidency& r = *residency;
  ClusterResidency::Slot& slot = r.frame[frameSlot];
  uint32_t pages = uint32_t(r.pageMesh.size());
  r.feedbackHost.resize(pages);
  std::memcpy(r.feedbackHost.data(), slot.readback.mapped(), pages * 4ull);
  r.haveFeedback = true;
  ResidencyStats st = slot.stats;
  for (uint32_t p = 0; p < pages; ++p) st.requested += r.feedbackHost[p] > 0.0f && !slot.resident[p];
  return st;
}

bool ClusterRenderer::hasResidency() const { return impl_->residency != nullptr; }

Result<ClusterRenderer::Converged> ClusterRenderer::renderConverged(const ClusterRenderSettings& settings,
                                                                    uint32_t maxFrames) {
  Converged out;
  if (!impl_->residency) {
    auto o = render(settings);
    if (!o) return o.error();
    out.output = std::move(*o);
    out.converged = true;
    return out;
  }
  ClusterRenderSettings quiet = settings;
  quiet.base.readImage = false;
  quiet.base.readLinear = false;
  quiet.readOwnedClusters = false;
  for (uint32_t frame = 0; frame < maxFrames; ++frame) {
    auto o = render(quiet);
    if (!o) return o.error();
    const ResidencyStats& st = o->stats.residency;
    out.frames.push_back(st);
    if (st.stepped && st.uploaded == 0 && st.evicted == 0) {
      out.framesToConverge = frame;
      out.converged = true;
      break;
    }
  }
  if (!out.converged) out.framesToConverge = maxFrames;
  auto o = render(settings); // the stable residency again, read back as asked
  if (!o) return o.error();
  out.frames.push_back(o->stats.residency);
  out.output = std::move(*o);
  return out;
}

} // namespace mirage::render
