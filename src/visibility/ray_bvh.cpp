// Host build of the compute traversal's BVH (ray_bvh.h). Embree's generic builder does the SAH
// work (binning, optionally spatial splits, parallel over TBB); its callbacks build a small pointer tree in
// Embree's thread-local memory, which is then laid out depth-first into 64-byte nodes.
#include "ray_bvh.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <embree3/rtcore.h>

#include "mirage/visibility/ray_backend.h"

namespace mirage::vis::detail {

namespace {

struct FlatTriangle {
  glm::vec3 v[3];
  uint32_t id;
  bool seeThrough;
};

// The builder's tree: inner nodes with up to four boxes, leaves with their flat-triangle indices.
struct BuildNode {
  bool leaf = false;
  uint32_t count = 0; // leaf: triangles in `prims`; inner: children
  const uint32_t* prims = nullptr;
  RTCBounds bounds[4]{};
  BuildNode* child[4]{};
};

void* createNode(RTCThreadLocalAllocator alloc, unsigned int /*childCount*/, void* /*user*/) {
  return new (rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16)) BuildNode{};
}

void setNodeChildren(void* node, void** children, unsigned int count, void* /*user*/) {
  auto* n = static_cast<BuildNode*>(node);
  n->count = std::min(count, 4u);
  for (unsigned int i = 0; i < n->count; ++i) n->child[i] = static_cast<BuildNode*>(children[i]);
}

void setNodeBounds(void* node, const RTCBounds** bounds, unsigned int count, void* /*user*/) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned int i = 0; i < std::min(count, 4u); ++i) n->bounds[i] = *bounds[i];
}

void* createLeaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count, void* /*user*/) {
  auto* ids = static_cast<uint32_t*>(rtcThreadLocalAlloc(alloc, std::max<size_t>(count, 1) * 4, 4));
  for (size_t i = 0; i < count; ++i) ids[i] = prims[i].primID;
  auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16)) BuildNode{};
  n->leaf = true;
  n->count = uint32_t(count);
  n->prims = ids;
  return n;
}

// Spatial split: the bounds of the triangle's parts on either side of the plane, within the
// reference's current bounds (which earlier splits may have cut already).
void splitPrimitive(const RTCBuildPrimitive* prim, unsigned int dim, float pos, RTCBounds* left, RTCBounds* right,
                    void* user) {
  const auto& tris = *static_cast<const std::vector<FlatTriangle>*>(user);
  const FlatTriangle& t = tris[prim->primID];
  glm::vec3 lo[2] = {glm::vec3(INFINITY), glm::vec3(INFINITY)}, hi[2] = {glm::vec3(-INFINITY), glm::vec3(-INFINITY)};
  auto add = [&](int side, glm::vec3 p) {
    lo[side] = glm::min(lo[side], p);
    hi[side] = glm::max(hi[side], p);
  };
  for (int k = 0; k < 3; ++k) {
    glm::vec3 a = t.v[k], b = t.v[(k + 1) % 3];
    if (a[dim] <= pos) add(0, a);
    if (a[dim] >= pos) add(1, a);
    if ((a[dim] < pos && b[dim] > pos) || (a[dim] > pos && b[dim] < pos)) {
      glm::vec3 p = glm::mix(a, b, (pos - a[dim]) / (b[dim] - a[dim]));
      p[dim] = pos;
      add(0, p);
      add(1, p);
    }
  }
  const glm::vec3 plo(prim->lower_x, prim->lower_y, prim->lower_z), phi(prim->upper_x, prim->upper_y, prim->upper_z);
  RTCBounds* out[2] = {left, right};
  for (int side = 0; side < 2; ++side) {
    glm::vec3 l = glm::max(lo[side], plo), h = glm::min(hi[side], phi);
    if (side == 0) h[dim] = std::min(h[dim], pos);
    if (side == 1) l[dim] = std::max(l[dim], pos);
    l = glm::min(l, h); // an empty part (rounding) becomes a point on the plane
    *out[side] = {l.x, l.y, l.z, 0.0f, h.x, h.y, h.z, 0.0f};
  }
}

std::vector<FlatTriangle> flattenTriangles(const Scene& scene) {
  std::vector<uint64_t> offsets = triangleOffsets(scene);
  std::vector<FlatTriangle> tris;
  tris.reserve(offsets.back());
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    const Mesh& mesh = scene.meshes[inst.mesh];
    bool seeThrough =
        mesh.material < scene.materials.size() && scene.materials[mesh.material].alphaMode != AlphaMode::Opaque;
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      FlatTriangle f;
      bool finite = true;
      for (int k = 0; k < 3; ++k) {
        f.v[k] = glm::vec3(inst.transform * glm::vec4(mesh.positions[mesh.indices[t * 3 + size_t(k)]], 1.0f));
        finite = finite && std::isfinite(f.v[k].x) && std::isfinite(f.v[k].y) && std::isfinite(f.v[k].z);
      }
      f.id = uint32_t(offsets[i] + t);
      f.seeThrough = seeThrough;
      if (finite) tris.push_back(f);
    }
  }
  return tris;
}

struct Layout {
  const std::vector<FlatTriangle>& tris;
  float pad;
  bool wide;
  RayBvh& out;

  // Depth-first: returns the child reference of `n` (a node index or LEAF | first triangle).
  uint32_t place(const BuildNode* n, uint32_t depth) {
    out.depth = std::max(out.depth, depth);
    if (n->leaf) {
      uint32_t first = uint32_t(out.triangles.size());
      for (uint32_t i = 0; i < n->count; ++i) {
        const FlatTriangle& t = tris[n->prims[i]];
        uint32_t flags =
            (i + 1 == n->count ? MIRAGE_RT_BVH_LAST : 0u) | (t.seeThrough ? MIRAGE_RT_BVH_SEE_THROUGH : 0u);
        out.triangles.push_back({t.v[0], t.id, t.v[1], flags, t.v[2], 0u});
      }
      return MIRAGE_RT_BVH_LEAF | first;
    }
    if (wide) return placeWide(n, depth);
    // A binary node with one child (never made by the builder) repeats it.
    uint32_t index = uint32_t(out.nodes.size());
    out.nodes.emplace_back();
    const RTCBounds boxes[2] = {n->bounds[0], n->bounds[n->count > 1 ? 1 : 0]};
    setBoxes(index, boxes);
    uint32_t c0 = place(n->child[0], depth + 1);
    uint32_t c1 = n->count > 1 ? place(n->child[1], depth + 1) : c0;
    out.nodes[index].child0 = c0;
    out.nodes[index].child1 = c1;
    return index;
  }

  uint32_t placeWide(const BuildNode* n, uint32_t depth) {
    uint32_t index = uint32_t(out.nodes4.size());
    out.nodes4.emplace_back();
    for (uint32_t c = 0; c < 4; ++c) {
      shaderio::RtBvh4Node& w = out.nodes4[index];
      const RTCBounds& b = n->bounds[c];
      bool used = c < n->count;
      w.loX[c] = used ? b.lower_x - pad : 0.0f;
      w.loY[c] = used ? b.lower_y - pad : 0.0f;
      w.loZ[c] = used ? b.lower_z - pad : 0.0f;
      w.hiX[c] = used ? b.upper_x + pad : 0.0f;
      w.hiY[c] = used ? b.upper_y + pad : 0.0f;
      w.hiZ[c] = used ? b.upper_z + pad : 0.0f;
      w.child[c] = MIRAGE_RT_BVH_NONE;
    }
    for (uint32_t c = 0; c < n->count; ++c) {
      uint32_t ref = place(n->child[c], depth + 1);
      out.nodes4[index].child[c] = ref; // after the recursion: it may grow the vector
    }
    return index;
  }

  // Boxes padded by a few ulps of the scene's coordinates: the shader's fma slab test rounds.
  void setBoxes(uint32_t index, const RTCBounds* b) {
    shaderio::RtBvhNode& n = out.nodes[index];
    n.lo0 = {b[0].lower_x - pad, b[0].lower_y - pad, b[0].lower_z - pad};
    n.hi0x = b[0].upper_x + pad;
    n.hi0y = b[0].upper_y + pad;
    n.hi0z = b[0].upper_z + pad;
    n.lo1x = b[1].lower_x - pad;
    n.lo1y = b[1].lower_y - pad;
    n.lo1z = b[1].lower_z - pad;
    n.hi1x = b[1].upper_x + pad;
    n.hi1y = b[1].upper_y + pad;
    n.hi1z = b[1].upper_z + pad;
  }
};

} // namespace

Result<RayBvh> buildRayBvh(const Scene& scene, const RayBvhOptions& options) {
  const bool spatialSplits = options.spatialSplits;
  auto t0 = std::chrono::steady_clock::now();
  RayBvh out;
  std::vector<FlatTriangle> tris = flattenTriangles(scene);
  if (tris.empty()) return out;
  // Spatial splits add references; the builder may use the whole capacity.
  std::vector<RTCBuildPrimitive> prims(tris.size() * (spatialSplits ? 2 : 1));
  glm::vec3 sceneLo(INFINITY), sceneHi(-INFINITY);
  for (size_t i = 0; i < tris.size(); ++i) {
    glm::vec3 lo = glm::min(glm::min(tris[i].v[0], tris[i].v[1]), tris[i].v[2]);
    glm::vec3 hi = glm::max(glm::max(tris[i].v[0], tris[i].v[1]), tris[i].v[2]);
    prims[i] = {lo.x, lo.y, lo.z, 0u, hi.x, hi.y, hi.z, uint32_t(i)};
    sceneLo = glm::min(sceneLo, lo);
    sceneHi = glm::max(sceneHi, hi);
  }
  const glm::vec3 far = glm::max(glm::abs(sceneLo), glm::abs(sceneHi));
  const float extent = std::max({far.x, far.y, far.z});
  RTCDevice device = rtcNewDevice(nullptr);
  RTCBVH bvh = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  // Binned SAH by default; HIGH adds spatial splits (tighter boxes around long thin triangles, but
  // on gen:city:8 41% more leaf triangles and a 12x slower build: docs/visibility.md).
  args.buildQuality = spatialSplits ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
  const bool wide = options.width == 4;
  args.maxBranchingFactor = wide ? 4 : 2;
  // The shader's stack holds a sentinel and what each level pushes: one entry (binary), three (4-wide).
  args.maxDepth = wide ? (MIRAGE_RT_BVH_STACK - 2) / 3 : MIRAGE_RT_BVH_STACK - 2;
  args.minLeafSize = 1;
  args.maxLeafSize = std::clamp(options.maxLeafSize, 1u, uint32_t(RTC_BUILD_MAX_PRIMITIVES_PER_LEAF));
  args.traversalCost = 1.0f;
  args.intersectionCost = 1.0f;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = tris.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = createNode;
  args.setNodeChildren = setNodeChildren;
  args.setNodeBounds = setNodeBounds;
  args.createLeaf = createLeaf;
  args.splitPrimitive = splitPrimitive;
  args.userPtr = &tris;
  auto* root = static_cast<BuildNode*>(rtcBuildBVH(&args));
  RTCError error = rtcGetDeviceError(device);
  if (!root || error != RTC_ERROR_NONE) {
    rtcReleaseBVH(bvh);
    rtcReleaseDevice(device);
    return makeError(scene.source, "compute BVH: Embree build failed (error " + std::to_string(int(error)) + ")");
  }
  Layout layout{tris, extent * 0x1p-21f, wide, out};
  if (wide)
    out.nodes4.reserve(tris.size() / 2);
  else
    out.nodes.reserve(tris.size());
  out.triangles.reserve(tris.size() * 3 / 2);
  if (root->leaf) { // a root inner node whose only child is the one leaf
    BuildNode top;
    top.count = 1;
    top.child[0] = root;
    top.bounds[0] = {sceneLo.x, sceneLo.y, sceneLo.z, 0, sceneHi.x, sceneHi.y, sceneHi.z, 0};
    layout.place(&top, 0);
  } else {
    layout.place(root, 0);
  }
  rtcReleaseBVH(bvh); // frees the builder's tree
  rtcReleaseDevice(device);
  if (out.triangles.size() >= MIRAGE_RT_BVH_LEAF || std::max(out.nodes.size(), out.nodes4.size()) >= MIRAGE_RT_BVH_NONE)
    return makeError(scene.source, "compute BVH: more than 2^31 triangle references");
  out.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

} // namespace mirage::vis::detail
