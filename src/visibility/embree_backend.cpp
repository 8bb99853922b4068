// Embree 3 ray backend (ray_backend.h): one BVH over the flattened world-space triangles, or one
// BVH per mesh under an instance level; closest-hit queries on all cores through TBB.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mirage/visibility/ray_backend.h"

namespace mirage::vis {

namespace {
std::atomic<uint64_t> g_nextGeneration{1};
}

TriangleSet::TriangleSet(size_t triangleCount)
    : capacity_(triangleCount), generation_(g_nextGeneration++),
      words_(new std::atomic<uint64_t>[(triangleCount + 63) / 64]()) {}

size_t TriangleSet::count() const {
  size_t n = 0;
  for (size_t w = 0; w < (capacity_ + 63) / 64; ++w) n += size_t(std::popcount(words_[w].load()));
  return n;
}

std::vector<uint32_t> TriangleSet::sorted() const {
  std::vector<uint32_t> out;
  for (size_t w = 0; w < (capacity_ + 63) / 64; ++w)
    for (uint64_t bits = words_[w].load(); bits; bits &= bits - 1)
      out.push_back(uint32_t(w * 64 + size_t(std::countr_zero(bits))));
  return out;
}

void TriangleSet::snapshot(std::vector<uint64_t>& words) const {
  words.resize((capacity_ + 63) / 64);
  for (size_t w = 0; w < words.size(); ++w) words[w] = words_[w].load(std::memory_order_relaxed);
}

void TriangleSet::assign(std::span<const uint32_t> ids) {
  generation_ = g_nextGeneration++;
  for (size_t w = 0; w < (capacity_ + 63) / 64; ++w) words_[w].store(0);
  for (uint32_t id : ids) insert(id);
}

std::vector<uint64_t> triangleOffsets(const Scene& scene) {
  std::vector<uint64_t> offsets{0};
  for (const Instance& inst : scene.instances)
    offsets.push_back(offsets.back() + scene.meshes[inst.mesh].triangleCount());
  return offsets;
}

std::array<glm::vec3, 3> worldTriangle(const Scene& scene, std::span<const uint64_t> offsets, uint32_t id) {
  size_t i = size_t(std::upper_bound(offsets.begin(), offsets.end(), uint64_t(id)) - offsets.begin()) - 1;
  const Instance& inst = scene.instances[i];
  const Mesh& mesh = scene.meshes[inst.mesh];
  size_t local = id - offsets[i];
  std::array<glm::vec3, 3> out;
  for (int k = 0; k < 3; ++k)
    out[k] = glm::vec3(inst.transform * glm::vec4(mesh.positions[mesh.indices[local * 3 + size_t(k)]], 1.0f));
  return out;
}

namespace {

constexpr uint32_t kMaxCandidates = 64; // see-through hits remembered per ray (or per packet)

struct Candidate {
  uint32_t id;
  float t;
  uint32_t lane;
};

class EmbreeBackend;

// Embree hands the filter callback the context pointer it was traced with; extending the context
// is the documented way to get per-ray state into it without globals.
struct FilterContext {
  RTCIntersectContext base;
  const EmbreeBackend* self;
  const TriangleSet* only; // TraceSets::onlyRequired: hits outside this set do not exist
  uint32_t count;
  Candidate candidates[kMaxCandidates];
};

class EmbreeBackend final : public RayBackend {
public:
  ~EmbreeBackend() override {
    if (scene_) rtcReleaseScene(scene_);
    for (RTCScene s : meshScenes_) rtcReleaseScene(s);
    if (device_) rtcReleaseDevice(device_);
  }
  std::string_view name() const override { return instanced_ ? "embree-instanced" : "embree"; }
  size_t triangleCount() const override { return triangles_; }

  Status build(const Scene& scene, const EmbreeOptions& options);
  void trace(std::span<const Ray> rays, std::span<Hit> hits, const TraceSets& sets) override;

  uint32_t globalId(uint32_t geomID, uint32_t primID, uint32_t instID) const {
    if (instanced_) return uint32_t(offsets_[instID] + primID);
    return flatIds_[geomID][primID];
  }

private:
  void traceOne(const Ray& ray, Hit& hit, const TraceSets& sets) const;
  void trace16(const Ray* rays, Hit* hits, uint32_t n, const TraceSets& sets) const;
  void finish(Hit& hit, const FilterContext& ctx, uint32_t lane, const TraceSets& sets) const;
  void initContext(FilterContext& ctx, const TraceSets& sets) const;

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<RTCScene> meshScenes_;
  bool instanced_ = false;
  bool packets_ = false;
  size_t triangles_ = 0;
  std::vector<uint64_t> offsets_;
  std::vector<uint32_t> flatIds_[2]; // geometry 0 opaque, 1 see-through: local primitive → global ID
};

void seeThroughFilter(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<FilterContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    RTCHit h = rtcGetHitFromHitN(args->hit, args->N, i);
    RTCRay r = rtcGetRayFromRayN(args->ray, args->N, i);
    if (ctx->count < kMaxCandidates)
      ctx->candidates[ctx->count++] = {ctx->self->globalId(h.geomID, h.primID, h.instID[0]), r.tfar, i};
    args->valid[i] = 0; // reject the hit: the ray goes on to what lies behind
  }
}

// The context filter, installed only for onlyRequired traces: hits on triangles outside the set are
// rejected, so the ray sees the scene reduced to that set (the PVS-only render).
void onlyRequiredFilter(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<FilterContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    RTCHit h = rtcGetHitFromHitN(args->hit, args->N, i);
    if (!ctx->only->contains(ctx->self->globalId(h.geomID, h.primID, h.instID[0]))) args->valid[i] = 0;
  }
}

bool seeThrough(const Scene& scene, const Mesh& mesh) {
  if (mesh.material >= scene.materials.size()) return false;
  return scene.materials[mesh.material].alphaMode != AlphaMode::Opaque;
}

RTCGeometry newTriangles(RTCDevice device, size_t vertices, size_t triangles, glm::vec3** v, uint32_t** idx) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  *v = static_cast<glm::vec3*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(glm::vec3), vertices));
  *idx = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), triangles));
  return g;
}

Status EmbreeBackend::build(const Scene& scene, const EmbreeOptions& options) {
  offsets_ = triangleOffsets(scene);
  triangles_ = offsets_.back();
  if (triangles_ >= kNoHit) return makeError(scene.source, "more than 4 G triangles: PVS IDs are 32-bit");
  device_ = rtcNewDevice(nullptr);
  if (!device_) return makeError(scene.source, "Embree device creation failed");
  packets_ = options.packets;
  instanced_ = options.geometry == EmbreeOptions::Geometry::Instance ||
               (options.geometry == EmbreeOptions::Geometry::Auto && triangles_ >= 4 * scene.meshTriangleCount());
  scene_ = rtcNewScene(device_);
  if (instanced_) {
    for (const Mesh& mesh : scene.meshes) {
      RTCScene ms = rtcNewScene(device_);
      // Instanced scenes run the context filter of the top-level trace too.
      rtcSetSceneFlags(ms, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
      glm::vec3* v = nullptr;
      uint32_t* idx = nullptr;
      RTCGeometry g = newTriangles(device_, mesh.positions.size(), mesh.triangleCount(), &v, &idx);
      std::memcpy(v, mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
      std::memcpy(idx, mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t));
      if (seeThrough(scene, mesh)) rtcSetGeometryIntersectFilterFunction(g, seeThroughFilter);
      rtcCommitGeometry(g);
      rtcAttachGeometry(ms, g);
      rtcReleaseGeometry(g);
      rtcCommitScene(ms);
      meshScenes_.push_back(ms);
    }
    for (uint32_t i = 0; i < scene.instances.size(); ++i) {
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(g, meshScenes_[scene.instances[i].mesh]);
      rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &scene.instances[i].transform[0][0]);
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(scene_, g, i);
      rtcReleaseGeometry(g);
    }
  } else {
    // Two geometries so only see-through triangles pay for the filter callback.
    size_t verts[2] = {0, 0}, tris[2] = {0, 0};
    for (const Instance& inst : scene.instances) {
      const Mesh& m = scene.meshes[inst.mesh];
      int k = seeThrough(scene, m) ? 1 : 0;
      verts[k] += m.positions.size();
      tris[k] += m.triangleCount();
    }
    for (int k = 0; k < 2; ++k) {
      glm::vec3* v = nullptr;
      uint32_t* idx = nullptr;
      RTCGeometry g = newTriangles(device_, std::max<size_t>(verts[k], 1), std::max<size_t>(tris[k], 1), &v, &idx);
      flatIds_[k].reserve(tris[k]);
      size_t vbase = 0, tbase = 0;
      for (size_t i = 0; i < scene.instances.size(); ++i) {
        const Instance& inst = scene.instances[i];
        const Mesh& m = scene.meshes[inst.mesh];
        if ((seeThrough(scene, m) ? 1 : 0) != k) continue;
        for (size_t p = 0; p < m.positions.size(); ++p)
          v[vbase + p] = glm::vec3(inst.transform * glm::vec4(m.positions[p], 1.0f));
        for (size_t t = 0; t < m.indices.size(); ++t) idx[tbase * 3 + t] = uint32_t(vbase + m.indices[t]);
        for (size_t t = 0; t < m.triangleCount(); ++t) flatIds_[k].push_back(uint32_t(offsets_[i] + t));
        vbase += m.positions.size();
        tbase += m.triangleCount();
      }
      if (tris[k] == 0) { // an empty geometry is not allowed: one degenerate triangle, never hit
        v[0] = glm::vec3(0.0f);
        idx[0] = idx[1] = idx[2] = 0;
        flatIds_[k].push_back(0);
      }
      if (k == 1) rtcSetGeometryIntersectFilterFunction(g, seeThroughFilter);
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(scene_, g, unsigned(k));
      rtcReleaseGeometry(g);
    }
  }
  // High-quality builds cost ~2x build time but trace faster: worth it for the many rays of a bake.
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  // Context filters (onlyRequired traces); a null-pointer test per hit for every other trace.
  rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
  rtcCommitScene(scene_);
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) return makeError(scene.source, "Embree scene build failed");
  return Ok{};
}

void EmbreeBackend::initContext(FilterContext& ctx, const TraceSets& sets) const {
  rtcInitIntersectContext(&ctx.base);
  ctx.self = this;
  ctx.only = sets.onlyRequired ? sets.require : nullptr;
  if (ctx.only) ctx.base.filter = onlyRequiredFilter;
  ctx.count = 0;
}

void EmbreeBackend::finish(Hit& hit, const FilterContext& ctx, uint32_t lane, const TraceSets& sets) const {
  hit.flags = 0;
  if (sets.record && hit.triangle != kNoHit && sets.record->insert(hit.triangle)) hit.flags |= kHitNew;
  if (sets.require && hit.triangle != kNoHit && !sets.require->contains(hit.triangle)) hit.flags |= kHitMissing;
  // See-through candidates count only in front of the closest opaque hit: the filter also saw
  // ones the traversal later found to lie behind it.
  hit.seeThrough = kNoHit;
  float nearest = hit.t;
  bool nearestNew = false;
  for (uint32_t c = 0; c < ctx.count; ++c) {
    const Candidate& cand = ctx.candidates[c];
    if (cand.lane != lane || (hit.triangle != kNoHit && cand.t >= hit.t)) continue;
    if (ctx.only && !ctx.only->contains(cand.id)) continue;
    bool fresh = sets.record && sets.record->insert(cand.id);
    if (sets.require && !sets.require->contains(cand.id)) hit.flags |= kHitMissing;
    // Candidates arrive in traversal order: keep the nearest, whose discovery then seeds ABS.
    if (hit.seeThrough == kNoHit || cand.t < nearest) {
      hit.seeThrough = cand.id;
      nearest = cand.t;
      nearestNew = fresh;
    } else if (cand.id == hit.seeThrough) {
      nearestNew |= fresh; // the filter may report one triangle twice
    }
  }
  if (nearestNew) hit.flags |= kHitSeeThroughNew;
}

void EmbreeBackend::traceOne(const Ray& ray, Hit& hit, const TraceSets& sets) const {
  if (!validRay(ray)) {
    hit = Hit{.t = ray.tfar};
    return;
  }
  FilterContext ctx;
  initContext(ctx, sets);
  RTCRayHit rh;
  rh.ray.org_x = ray.origin.x;
  rh.ray.org_y = ray.origin.y;
  rh.ray.org_z = ray.origin.z;
  rh.ray.tnear = ray.tnear;
  rh.ray.dir_x = ray.dir.x;
  rh.ray.dir_y = ray.dir.y;
  rh.ray.dir_z = ray.dir.z;
  rh.ray.time = 0.0f;
  rh.ray.tfar = ray.tfar;
  rh.ray.mask = ~0u;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &ctx.base, &rh);
  bool found = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  hit.triangle = found ? globalId(rh.hit.geomID, rh.hit.primID, rh.hit.instID[0]) : kNoHit;
  hit.t = found ? rh.ray.tfar : ray.tfar;
  finish(hit, ctx, 0, sets);
}

void EmbreeBackend::trace16(const Ray* rays, Hit* hits, uint32_t n, const TraceSets& sets) const {
  FilterContext ctx;
  initContext(ctx, sets);
  ctx.base.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) int valid[16];
  alignas(64) RTCRayHit16 rh;
  // Inactive lanes still carry a valid ray: Debian's Embree asserts ray.valid() on lanes the
  // coherent path handles together, masked or not (a NaN in one lane aborted the whole packet).
  const Ray idle{.dir = {0.0f, 0.0f, 1.0f}, .tfar = 0.0f};
  for (uint32_t i = 0; i < 16; ++i) {
    const bool active = i < n && validRay(rays[i]);
    const Ray& r = active ? rays[i] : idle;
    valid[i] = active ? -1 : 0;
    rh.ray.org_x[i] = r.origin.x;
    rh.ray.org_y[i] = r.origin.y;
    rh.ray.org_z[i] = r.origin.z;
    rh.ray.tnear[i] = r.tnear;
    rh.ray.dir_x[i] = r.dir.x;
    rh.ray.dir_y[i] = r.dir.y;
    rh.ray.dir_z[i] = r.dir.z;
    rh.ray.time[i] = 0.0f;
    rh.ray.tfar[i] = r.tfar;
    rh.ray.mask[i] = ~0u;
    rh.ray.id[i] = i;
    rh.ray.flags[i] = 0;
    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
  }
  rtcIntersect16(valid, scene_, &ctx.base, &rh);
  for (uint32_t i = 0; i < n; ++i) {
    bool found = valid[i] && rh.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID;
    hits[i].triangle = found ? globalId(rh.hit.geomID[i], rh.hit.primID[i], rh.hit.instID[0][i]) : kNoHit;
    hits[i].t = found ? rh.ray.tfar[i] : rays[i].tfar;
    finish(hits[i], ctx, i, sets);
  }
}

void EmbreeBackend::trace(std::span<const Ray> rays, std::span<Hit> hits, const TraceSets& sets) {
  size_t n = std::min(rays.size(), hits.size());
  if (packets_ && sets.coherent) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, (n + 15) / 16, 64), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t p = r.begin(); p < r.end(); ++p)
        trace16(&rays[p * 16], &hits[p * 16], uint32_t(std::min<size_t>(16, n - p * 16)), sets);
    });
    return;
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) traceOne(rays[i], hits[i], sets);
  });
}

} // namespace

Result<std::unique_ptr<RayBackend>> createEmbreeBackend(const Scene& scene, const EmbreeOptions& options) {
  auto backend = std::make_unique<EmbreeBackend>();
  if (auto ok = backend->build(scene, options); !ok) return ok.error();
  return std::unique_ptr<RayBackend>(std::move(backend));
}

} // namespace mirage::vis
