#pragma once
// Ray casting behind one small interface, so the GVS++ sampler and the pixel-error evaluation run
// unchanged on Embree (CPU, this file) and later on Vulkan ray tracing. Triangles carry global IDs:
// instance-major over Scene::instances, each instance's mesh triangles in index order
// (triangleOffsets). Back faces are hit (visibility ignores culling). Triangles whose material is
// Blend or Mask are "see-through": a ray records them but continues, because the renderer shows
// what lies behind glass and alpha-tested cut-outs.
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

inline constexpr uint32_t kNoHit = ~0u;

struct Ray {
  glm::vec3 origin{0.0f};
  float tnear = 0.0f;
  glm::vec3 dir{0.0f, 0.0f, 1.0f}; // need not be unit length; t is in units of |dir|
  float tfar = std::numeric_limits<float>::infinity();
};
static_assert(sizeof(Ray) == 32);

// Largest |coordinate| of a ray's origin or direction any backend traces: Embree asserts beyond
// its FLT_LARGE (1.844e18), and no float hit test means anything that far out.
inline constexpr float kMaxRayCoordinate = 1e18f;

// What every backend traces; anything else (NaN, infinities, huge coordinates, a zero direction,
// an inverted interval) is reported as a miss, and the samplers never make such rays.
inline bool validRay(const Ray& r) {
  auto inRange = [](glm::vec3 v) {
    return std::abs(v.x) <= kMaxRayCoordinate && std::abs(v.y) <= kMaxRayCoordinate &&
           std::abs(v.z) <= kMaxRayCoordinate; // false for NaN
  };
  return inRange(r.origin) && inRange(r.dir) && glm::dot(r.dir, r.dir) > 0.0f && r.tnear >= 0.0f && r.tnear <= r.tfar;
}

enum HitFlags : uint32_t {
  kHitNew = 1,           // this ray's closest (opaque) hit was the first insertion of its triangle into `record`
  kHitMissing = 2,       // a triangle this ray sees (see-through ones in front, or the closest) is not in `require`
  kHitSeeThroughNew = 4, // this ray's insert of `seeThrough` into `record` was the first
};

struct Hit {
  uint32_t triangle = kNoHit; // closest opaque hit, global ID, or kNoHit
  float t = 0.0f;
  uint32_t flags = 0;
  uint32_t seeThrough = kNoHit; // nearest see-through triangle in front of `triangle`, or kNoHit
};

// A set of triangle IDs as an atomic bit array: insert() from any thread, so rays deduplicate
// discoveries where they are traced and the host never merges per-thread lists.
class TriangleSet {
public:
  explicit TriangleSet(size_t triangleCount = 0);
  size_t capacity() const { return capacity_; }
  // True when this call set the bit (the first insertion).
  bool insert(uint32_t id) {
    // Read first: most hits land on triangles already found, and a plain load keeps the cache line
    // shared between cores where an atomic read-modify-write would take it exclusive every time.
    if (contains(id)) return false;
    uint64_t bit = uint64_t(1) << (id & 63);
    return !(words_[id >> 6].fetch_or(bit, std::memory_order_relaxed) & bit);
  }
  bool contains(uint32_t id) const { return words_[id >> 6].load(std::memory_order_relaxed) >> (id & 63) & 1; }
  size_t count() const;
  std::vector<uint32_t> sorted() const;
  void assign(std::span<const uint32_t> ids);
  // Unique per set and per assign(): a GPU copy of the set (vulkan_backend.cpp) knows when to upload
  // it again (insertions it sees through count()).
  uint64_t generation() const { return generation_; }
  // The words themselves, read-only (64 IDs each, little endian), for uploads.
  const std::atomic<uint64_t>* words() const { return words_.get(); }
  // The bits as plain words (64 IDs each), e.g. to tell later which IDs a batch of rays added.
  void snapshot(std::vector<uint64_t>& words) const;

private:
  size_t capacity_ = 0;
  uint64_t generation_ = 0;
  std::unique_ptr<std::atomic<uint64_t>[]> words_;
};

// What a trace updates besides the hits; both optional.
struct TraceSets {
  TriangleSet* record = nullptr;        // every triangle a ray sees is inserted (kHitNew reports the closest)
  const TriangleSet* require = nullptr; // kHitMissing when a seen triangle is not in here
  bool coherent = false;                // a hint: neighbouring rays share origin and direction (views)
  bool onlyRequired = false;            // trace the scene reduced to `require` (a PVS-only render)
};

// GVS++ random rays of a view cell, for backends that make them where they are traced: ray i of a
// call is the randomized Halton point firstIndex + i + 1 (bases 2, 3, 5, 7, 11: face by area, u, v
// on the face, two coordinates of a uniform sphere direction) shifted by `offset`, exactly the
// map of the host sampler (src/visibility/sampling.h).
struct CellRaySource {
  std::span<const CellFace> faces;
  std::span<const float> cdf; // cumulative area fractions, one per face (the last is 1)
  std::array<float, 5> offset{};
  uint64_t firstIndex = 0;
};

// A first discovery of a generated trace: the triangle and the lowest ray index (within the call)
// whose closest or nearest see-through hit it was.
struct FirstHit {
  uint32_t triangle;
  uint32_t ray;
};

// GVS++ exploration rays for backends that make them where they are traced: adaptive border
// sampling (ABS) around discoveries, or reverse sampling (RS) from the cell towards
// discontinuities. Ray i of a call belongs to item i / raysPerItem, and is the ray the host
// sampler (gvs.cpp) makes in that item's slot i % raysPerItem with the formulas of
// shaderio/gvs_explore.h; slots the host leaves empty are skipped.
struct ExploreRaySource {
  enum class Kind { Border, Reverse } kind = Kind::Border;
  struct BorderItem {
    glm::vec3 origin; // of the ray that found `triangle`
    uint32_t triangle;
  };
  struct ReverseItem {
    glm::vec3 target;  // the border point an ABS ray aimed at
    uint32_t occluder; // what it hit nearer, or kNoHit
  };
  std::span<const BorderItem> border;   // Kind::Border
  std::span<const ReverseItem> reverse; // Kind::Reverse
  uint32_t raysPerItem = 1;
  // ABS: edge samples, border enlargement (relative to the longest edge, plus absolute), and the
  // discontinuity threshold (relative to the target's distance).
  uint32_t absEdgeSamples = 0;
  float absDeltaTriangle = 0.0f, absDeltaAbsolute = 0.0f, rsDeltaRelative = 0.0f;
  // RS: origins along the cell's edges, then Halton points on its faces (offsets: the RS
  // sequence's Cranley-Patterson rotation); item k is sequence index firstSeed + k.
  uint32_t rsEdgeSamples = 0, rsAreaSamples = 0;
  std::span<const std::array<glm::vec3, 2>> edges;
  std::span<const CellFace> faces;
  std::span<const float> cdf;
  std::array<float, 3> rsOffset{};
  uint64_t firstSeed = 0;
};

// An ABS ray that met a discontinuity: its target, what it hit (or kNoHit), its index in the call.
struct Discontinuity {
  glm::vec3 target;
  uint32_t occluder;
  uint32_t ray;
};

struct ExploreResult {
  std::vector<FirstHit> firstHits;            // as traceCellRays: (triangle, lowest ray), no particular order
  std::vector<Discontinuity> discontinuities; // Kind::Border, no particular order
  uint64_t traced = 0;                        // rays not skipped
  std::vector<Ray>* rays = nullptr;           // if set: every slot's ray (tfar < 0: skipped), for tests
};

class RayBackend {
public:
  virtual ~RayBackend() = default;
  virtual std::string_view name() const = 0;
  // Global triangle IDs are < triangleCount().
  virtual size_t triangleCount() const = 0;
  // Closest hits for every ray (hits.size() == rays.size()), on all cores.
  virtual void trace(std::span<const Ray> rays, std::span<Hit> hits, const TraceSets& sets = {}) = 0;
  // Rays per trace() call the sampler should batch: enough to fill the device (all CPU cores, or
  // a GPU, where each call also pays for a submission and the transfers).
  virtual size_t preferredBatchRays() const { return size_t(1) << 18; }
  // Traces `count` rays of `source` without per-ray traffic: every triangle seen goes into
  // `record`; `out` gets (triangle, lowest ray) for each closest or nearest see-through hit absent
  // from `record` before the call, in no particular order. The same discoveries as tracing the
  // rays through trace() and crediting the lowest-indexed ray. False (nothing traced) when the
  // backend cannot; the caller then makes the rays itself.
  virtual bool traceCellRays(const CellRaySource& /*source*/, size_t /*count*/, TriangleSet& /*record*/,
                             std::vector<FirstHit>& /*out*/) {
    return false;
  }
  // Traces the exploration rays of `source` (all items' slots) without per-ray traffic: every
  // triangle seen goes into `record`, first discoveries and (ABS) discontinuities come back. False
  // (nothing traced) when the backend cannot; the caller then makes the rays itself.
  virtual bool traceExploreRays(const ExploreRaySource& /*source*/, TriangleSet& /*record*/, ExploreResult& /*out*/) {
    return false;
  }
  // Queued forms of traceCellRays and traceExploreRays, for backends that trace on a device:
  // submit...() queues the trace and returns at once (false, nothing queued, when the backend
  // cannot); collect() waits for the oldest queued trace and gives what the synchronous call would
  // have (for cell rays: firstHits, and traced = count). Queued traces run in submission order,
  // each seeing `record` as the ones before it left it, so a sequence of them finds what the same
  // synchronous calls find; the host meanwhile works on what came back. At most maxQueued() (0:
  // the backend queues nothing) at once, all with the same `record`; the sources' spans need not
  // outlive the submission.
  virtual size_t maxQueued() const { return 0; }
  virtual bool submitCellRays(const CellRaySource& /*source*/, size_t /*count*/, TriangleSet& /*record*/) {
    return false;
  }
  virtual bool submitExploreRays(const ExploreRaySource& /*source*/, TriangleSet& /*record*/) { return false; }
  virtual void collect(TriangleSet& /*record*/, ExploreResult& /*out*/) {}
  // Another lane over the same scene, to trace from another thread at the same time as this one
  // (each lane its own sets and launches; the scene's device data, built once, shared): two cells
  // baked at once keep a device busy while each lane's host work runs. Null where a lane would
  // gain nothing (Embree: one bake already takes every core). Lanes must not outlive this backend.
  virtual std::unique_ptr<RayBackend> sibling() { return nullptr; }
  // How many lanes pay off: 2 on a GPU (measured on the H100: the 10-cell street bake 2.2 s on one
  // lane, 1.6 s on two, 1.5 s on three), 1 where the host is the device (lavapipe) or no sibling.
  virtual size_t preferredLanes() const { return 1; }
};

// First global triangle ID of each instance (size instances + 1; the last entry is the total).
std::vector<uint64_t> triangleOffsets(const Scene& scene);
// World-space corners of a global triangle (binary search over the offsets).
std::array<glm::vec3, 3> worldTriangle(const Scene& scene, std::span<const uint64_t> offsets, uint32_t id);

struct EmbreeOptions {
  // Flatten copies every instance's triangles into one world-space BVH; Instance builds one BVH per
  // mesh under a top level. Measured on one core (docs/visibility.md): on the instanced city
  // (gen:city:8) both trace at the same speed while Instance builds in 0.01 s instead of 1.4 s and stores
  // unique meshes only; on sponza and dream-apartment (every mesh used once, large overlapping
  // meshes) Instance traces 1.9-3.7x slower. Auto instances when instancing saves at least 4x the
  // triangles, and flattens otherwise.
  enum class Geometry { Auto, Flatten, Instance } geometry = Geometry::Auto;
  // rtcIntersect16 on packets of 16 consecutive rays for traces marked coherent (primary views);
  // GVS rays are incoherent and always go one by one (rtcIntersect1).
  bool packets = true;
};

// Embree 3 backend on all cores (TBB). Keeps a reference to nothing: the scene may be freed after.
Result<std::unique_ptr<RayBackend>> createEmbreeBackend(const Scene& scene, const EmbreeOptions& options = {});

} // namespace mirage::vis
