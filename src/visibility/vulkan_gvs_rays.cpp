// The Vulkan ray backend's GVS++ ray sources (vulkan_backend_impl.h): random rays of a cell
// (MODE_CELL) and border and reverse rays (MODE_BORDER / MODE_REVERSE, shaderio/gvs_explore.h),
// made in the shader that traces them; only discoveries and discontinuities come back. Up to two
// launches are queued at once (submit*, collect), each into its own Launch's buffers.
#include <cassert>
#include <chrono>
#include <utility>
#include <cstring>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "vulkan_backend_impl.h"

namespace mirage::vis::detail {

using namespace gpu;

void VulkanBackend::uploadWorldTriangles(const Scene& scene, std::span<const uint64_t> offsets) {
  // The corners as worldTriangle computes them, so host and device border rays agree.
  std::vector<glm::vec3> corners(sh_->triangles * 3);
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    const Mesh& mesh = scene.meshes[inst.mesh];
    for (size_t t = 0; t < offsets[i + 1] - offsets[i]; ++t)
      for (size_t k = 0; k < 3; ++k)
        corners[(offsets[i] + t) * 3 + k] =
            glm::vec3(inst.transform * glm::vec4(mesh.positions[mesh.indices[t * 3 + k]], 1.0f));
  }
  sh_->worldTriangles = createBufferWithData(ctx_, std::span<const glm::vec3>(corners),
                                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "rt world triangles");
}

bool VulkanBackend::traceCellRays(const CellRaySource& source, size_t count, TriangleSet& record,
                                  std::vector<FirstHit>& out) {
  assert(queued_ == 0);
  RayTiming total;
  ExploreResult part;
  for (size_t done = 0; done < count;) {
    // Launches of up to 2^30 rays (the smallest maxRayDispatchInvocationCount the spec allows).
    const size_t n = std::min<size_t>(count - done, size_t(1) << 30);
    auto t0 = std::chrono::steady_clock::now();
    CellRaySource launch = source;
    launch.firstIndex = source.firstIndex + done;
    if (!submitCellRays(launch, n, record)) return false;
    launches_[oldest_].firstRay = uint32_t(done);
    collect(record, part);
    out.insert(out.end(), part.firstHits.begin(), part.firstHits.end());
    total.gpuMilliseconds += timing_.gpuMilliseconds;
    total.wallMilliseconds += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    done += n;
  }
  timing_ = total;
  return true;
}

bool VulkanBackend::submitCellRays(const CellRaySource& source, size_t count, TriangleSet& record) {
  if (source.faces.empty() || source.faces.size() > MIRAGE_RT_MAX_CELL_FACES ||
      source.cdf.size() != source.faces.size() || count > (size_t(1) << 30) || queued_ == launches_.size())
    return false;
  shaderio::RtCellSource src{};
  src.before = before_.address();
  src.firstRay = firstRay_.address();
  src.faceCount = uint32_t(source.faces.size());
  src.offset0 = source.offset[0];
  src.offset1 = source.offset[1];
  src.offset2 = source.offset[2];
  src.offset3 = source.offset[3];
  src.offset4 = source.offset[4];
  for (size_t f = 0; f < source.faces.size(); ++f)
    src.faces[f] = {source.faces[f].corner, source.cdf[f], source.faces[f].edgeU, 0.0f, source.faces[f].edgeV, 0.0f};
  src.firstIndex = source.firstIndex;
  Launch& L = nextLaunch();
  std::memcpy(L.source.mapped(), &src, sizeof(src)); // L's previous launch has been collected
  shaderio::RtTracePush push{};
  push.record = record_.bits.address();
  push.count = uint32_t(count);
  push.mode = MIRAGE_RT_MODE_CELL;
  push.cell = L.source.address();
  return submitClaiming(push, record, 0, count);
}

bool VulkanBackend::submitClaiming(shaderio::RtTracePush push, TriangleSet& record, uint32_t firstRay, size_t count) {
  if (queued_ == launches_.size()) return false;
  Launch& L = nextLaunch();
  const bool upload = prepareSet(record_, &record);
  // A queued launch would still read the staging copy: the set may change only between launches.
  assert(!upload || queued_ == 0);
  L.mode = push.mode;
  L.count = count;
  L.firstRay = firstRay;
  L.cmd = ctx_.beginOneShot();
  cmdLaunch(L.cmd, L, push, upload, false, true, 0, sizeof(Ray));
  ctx_.endOneShotAndSubmit(L.cmd, L.done);
  firstRayValid_ = true;
  ++queued_;
  return true;
}

void VulkanBackend::collect(TriangleSet& record, ExploreResult& out) {
  assert(queued_ > 0);
  auto t0 = std::chrono::steady_clock::now();
  Launch& L = launches_[oldest_];
  const VkFence done = L.done.get();
  MIRAGE_VK_CHECK(vkWaitForFences(ctx_.device(), 1, &done, VK_TRUE, UINT64_MAX));
  MIRAGE_VK_CHECK(vkResetFences(ctx_.device(), 1, &done));
  ctx_.freeOneShot(std::exchange(L.cmd, VK_NULL_HANDLE));
  oldest_ = (oldest_ + 1) % launches_.size();
  --queued_;
  readTiming(L);
  out.firstHits.clear();
  out.discontinuities.clear();
  collectClaims(L, record, L.firstRay, out.firstHits);
  shaderio::RtCounters c;
  std::memcpy(&c, L.counters.mapped(), sizeof(c));
  out.traced = L.mode == MIRAGE_RT_MODE_CELL ? L.count : c.traced;
  if (L.mode == MIRAGE_RT_MODE_BORDER) {
    // Up to a discontinuity per ray (tens of MB): copied out on all cores.
    const auto* d = reinterpret_cast<const Discontinuity*>(L.discontinuities.mapped());
    out.discontinuities.resize(std::min<size_t>(c.discontinuities, L.count));
    tbb::parallel_for(tbb::blocked_range<size_t>(0, out.discontinuities.size(), size_t(1) << 15),
                      [&](const tbb::blocked_range<size_t>& r) {
                        std::memcpy(out.discontinuities.data() + r.begin(), d + r.begin(),
                                    r.size() * sizeof(Discontinuity));
                      });
  }
  timing_.wallMilliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void VulkanBackend::collectClaims(const Launch& L, TriangleSet& record, uint32_t firstRay, std::vector<FirstHit>& out) {
  const auto* first = reinterpret_cast<const uint32_t*>(L.firstRays.mapped());
  const auto* ids = reinterpret_cast<const uint32_t*>(L.newIds.mapped());
  shaderio::RtCounters c;
  std::memcpy(&c, L.counters.mapped(), sizeof(c));
  for (uint32_t k = 0; k < std::min<uint32_t>(c.newCount, uint32_t(sh_->triangles + 1)); ++k) {
    const uint32_t id = ids[k];
    record.insert(id);
    // Recorded but neither the closest nor the nearest see-through hit of any ray: no discovery.
    if (first[k] != ~0u) out.push_back({id, firstRay + first[k]});
  }
  record_.count = record.count();
}

bool VulkanBackend::traceExploreRays(const ExploreRaySource& source, TriangleSet& record, ExploreResult& out) {
  assert(queued_ == 0);
  auto t0 = std::chrono::steady_clock::now();
  keepExploreRays_ = out.rays != nullptr;
  const bool submitted = submitExploreRays(source, record);
  keepExploreRays_ = false;
  if (!submitted) return false;
  const size_t count = launches_[oldest_].count;
  collect(record, out);
  if (out.rays) {
    const auto* r = reinterpret_cast<const Ray*>(exploreRays_.mapped());
    out.rays->assign(r, r + count);
  }
  timing_.wallMilliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return true;
}

bool VulkanBackend::submitExploreRays(const ExploreRaySource& source, TriangleSet& record) {
  const bool border = source.kind == ExploreRaySource::Kind::Border;
  const size_t items = border ? source.border.size() : source.reverse.size();
  const size_t count = items * source.raysPerItem;
  if (!sh_->worldTriangles || source.raysPerItem == 0 || count >= (size_t(1) << 30) || queued_ == launches_.size() ||
      (!border && (source.edges.empty() || source.edges.size() > MIRAGE_RT_MAX_CELL_EDGES || source.faces.empty() ||
                   source.faces.size() > MIRAGE_RT_MAX_CELL_FACES || source.cdf.size() != source.faces.size())))
    return false;
  Launch& L = nextLaunch(); // its previous launch has been collected: its buffers are free
  const size_t itemBytes = std::max<size_t>(1, items) * sizeof(shaderio::RtBorderItem);
  ensureCapacity(L.items, itemBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "rt explore items");
  if (border)
    std::memcpy(L.items.mapped(), source.border.data(), items * sizeof(shaderio::RtBorderItem));
  else
    std::memcpy(L.items.mapped(), source.reverse.data(), items * sizeof(shaderio::RtReverseItem));
  shaderio::RtExploreSource src{};
  src.cell.before = before_.address();
  src.cell.firstRay = firstRay_.address();
  src.cell.faceCount = uint32_t(source.faces.size());
  for (size_t f = 0; f < source.faces.size(); ++f)
    src.cell.faces[f] = {source.faces[f].corner, source.cdf[f], source.faces[f].edgeU, 0.0f,
                         source.faces[f].edgeV,  0.0f};
  src.items = L.items.address();
  src.triangles = sh_->worldTriangles.address();
  if (border) {
    ensureCapacity(L.discontinuities, std::max<size_t>(1, count) * sizeof(shaderio::RtDiscontinuity),
                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Readback, "rt discontinuities");
    src.discontinuities = L.discontinuities.address();
  }
  if (keepExploreRays_) {
    ensureCapacity(exploreRays_, std::max<size_t>(1, count) * sizeof(Ray), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                   MemoryUsage::Readback, "rt explore rays");
    src.rays = exploreRays_.address();
  }
  src.firstSeed = source.firstSeed;
  src.raysPerItem = source.raysPerItem;
  src.absEdgeSamples = source.absEdgeSamples;
  src.absDeltaTriangle = source.absDeltaTriangle;
  src.absDeltaAbsolute = source.absDeltaAbsolute;
  src.rsDeltaRelative = source.rsDeltaRelative;
  src.rsEdgeSamples = source.rsEdgeSamples;
  src.rsAreaSamples = source.rsAreaSamples;
  src.edgeCount = uint32_t(source.edges.size());
  for (size_t e = 0; e < source.edges.size(); ++e) {
    // The length as the host's edgePoint measures it.
    const float length = glm::length(source.edges[e][1] - source.edges[e][0]);
    src.edges[e] = {source.edges[e][0], length, source.edges[e][1], 0.0f};
    src.edgeLength += length;
  }
  src.rsOffset0 = source.rsOffset[0];
  src.rsOffset1 = source.rsOffset[1];
  src.rsOffset2 = source.rsOffset[2];
  std::memcpy(L.source.mapped(), &src, sizeof(src));
  shaderio::RtTracePush push{};
  push.record = record_.bits.address();
  push.count = uint32_t(count);
  push.mode = border ? MIRAGE_RT_MODE_BORDER : MIRAGE_RT_MODE_REVERSE;
  push.cell = L.source.address();
  return submitClaiming(push, record, 0, count);
}

} // namespace mirage::vis::detail
