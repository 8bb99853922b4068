// Host build of the compute traversal's BVH (ray_bvh.h). Embree's generic builder does the SAH
// work (binning, optionally spatial splits, parallel over TBB); its callbacks build a small pointer tree in
// Embree's thread-local memory, which is then laid out depth-first into 64-byte nodes.
#include "ray_bvh.h"

#include <algorithm>
#include <array>
#include <bit>
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

// The builder's tree: inner nodes with up to eight boxes, leaves with their flat-triangle indices.
constexpr unsigned kMaxChildren = 8;
struct BuildNode {
  bool leaf = false;
  uint32_t count = 0; // leaf: triangles in `prims`; inner: children
  const uint32_t* prims = nullptr;
  RTCBounds bounds[kMaxChildren]{};
  BuildNode* child[kMaxChildren]{};
};

void* createNode(RTCThreadLocalAllocator alloc, unsigned int /*childCount*/, void* /*user*/) {
  return new (rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16)) BuildNode{};
}

void setNodeChildren(void* node, void** children, unsigned int count, void* /*user*/) {
  auto* n = static_cast<BuildNode*>(node);
  n->count = std::min(count, kMaxChildren);
  for (unsigned int i = 0; i < n->count; ++i) n->child[i] = static_cast<BuildNode*>(children[i]);
}

void setNodeBounds(void* node, const RTCBounds** bounds, unsigned int count, void* /*user*/) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned int i = 0; i < std::min(count, kMaxChildren); ++i) n->bounds[i] = *bounds[i];
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

// One child of an 8-wide node: an inner builder node, or a run of triangles (a builder leaf, or a
// part of one too long for a slot, which becomes a node of its own).
struct Child8 {
  glm::vec3 lo, hi;                // the child's box, unpadded
  const BuildNode* node = nullptr; // an inner builder node
  const uint32_t* prims = nullptr; // else a run of flat-triangle indices
  uint32_t count = 0;
  bool leaf() const { return node == nullptr && count <= MIRAGE_RT_BVH8_LEAF_MAX; }
};

// Quantization of one axis: the step 2^e with 255 steps covering the node's extent.
int bvh8Exponent(double extent) {
  if (!(extent > 0.0)) return -100;
  int ex = 0;
  double m = std::frexp(extent / 255.0, &ex); // extent / 255 = m * 2^ex, m in [0.5, 1)
  return std::clamp(m == 0.5 ? ex - 1 : ex, -126, 127);
}

struct Layout8 {
  const std::vector<FlatTriangle>& tris;
  float pad;
  RayBvh& out;

  Child8 fromBuilder(const BuildNode* n, const RTCBounds& b) const {
    Child8 c{{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
    if (n->leaf) {
      c.prims = n->prims;
      c.count = n->count;
    } else {
      c.node = n;
    }
    return c;
  }

  // A run of triangles, its box clipped to the parent's (spatial splits cut references).
  Child8 run(const uint32_t* prims, uint32_t count, glm::vec3 clipLo, glm::vec3 clipHi) const {
    Child8 c{glm::vec3(INFINITY), glm::vec3(-INFINITY), nullptr, prims, count};
    for (uint32_t i = 0; i < count; ++i)
      for (const glm::vec3& v : tris[prims[i]].v) {
        c.lo = glm::min(c.lo, v);
        c.hi = glm::max(c.hi, v);
      }
    c.lo = glm::max(c.lo, clipLo);
    c.hi = glm::max(glm::min(c.hi, clipHi), c.lo);
    return c;
  }

  std::vector<Child8> children(const Child8& c) const {
    std::vector<Child8> kids;
    if (c.node) {
      for (uint32_t i = 0; i < c.node->count; ++i)
        if (!c.node->child[i]->leaf || c.node->child[i]->count > 0)
          kids.push_back(fromBuilder(c.node->child[i], c.node->bounds[i]));
      return kids;
    }
    // A long run: up to eight parts, leaves of three when they fit, else shorter runs.
    const uint32_t part = std::max(MIRAGE_RT_BVH8_LEAF_MAX, (c.count + kMaxChildren - 1) / kMaxChildren);
    for (uint32_t first = 0; first < c.count; first += part)
      kids.push_back(run(c.prims + first, std::min(part, c.count - first), c.lo, c.hi));
    return kids;
  }

  // Slot s takes the child nearest first for rays of octant s: greedily, the (child, slot) pair
  // with the lowest projection of the child's centre on the octant's direction first (Ylitie et
  // al. solve the same assignment exactly; greedy is their cheaper alternative).
  static std::array<int, kMaxChildren> assignSlots(const std::vector<Child8>& kids, glm::vec3 lo, glm::vec3 hi) {
    std::array<int, kMaxChildren> kidOfSlot;
    kidOfSlot.fill(-1);
    const glm::vec3 centre = 0.5f * (lo + hi);
    float cost[kMaxChildren][kMaxChildren];
    for (size_t k = 0; k < kids.size(); ++k)
      for (uint32_t s = 0; s < kMaxChildren; ++s) {
        glm::vec3 dir(s & 1 ? -1.0f : 1.0f, s & 2 ? -1.0f : 1.0f, s & 4 ? -1.0f : 1.0f);
        cost[k][s] = glm::dot(0.5f * (kids[k].lo + kids[k].hi) - centre, dir);
      }
    std::array<bool, kMaxChildren> placed{};
    for (size_t round = 0; round < kids.size(); ++round) {
      int bestK = -1, bestS = -1;
      for (size_t k = 0; k < kids.size(); ++k)
        for (uint32_t s = 0; s < kMaxChildren; ++s)
          if (!placed[k] && kidOfSlot[s] < 0 && (bestK < 0 || cost[k][s] < cost[bestK][bestS])) {
            bestK = int(k);
            bestS = int(s);
          }
      placed[size_t(bestK)] = true;
      kidOfSlot[size_t(bestS)] = bestK;
    }
    return kidOfSlot;
  }

  // Writes node `index` (already allocated) for the children of `c`, then its inner children.
  void place(const Child8& c, uint32_t index, uint32_t depth) {
    out.depth = std::max(out.depth, depth);
    std::vector<Child8> kids = children(c);
    for (Child8& k : kids) { // padded: the shader's fma slab test rounds
      k.lo -= pad;
      k.hi += pad;
    }
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const Child8& k : kids) {
      lo = glm::min(lo, k.lo);
      hi = glm::max(hi, k.hi);
    }
    const std::array<int, kMaxChildren> kidOfSlot = assignSlots(kids, lo, hi);
    shaderio::RtBvh8Node n{};
    n.origin = lo;
    int e[3];
    for (int a = 0; a < 3; ++a) {
      e[a] = bvh8Exponent(double(hi[a]) - double(lo[a]));
      n.exponents |= uint32_t(e[a] + 127) << (8 * a);
    }
    n.childBase = uint32_t(out.nodes8.size());
    n.triangleBase = uint32_t(out.triangles.size());
    std::vector<const Child8*> inner;
    uint32_t offset = 0;
    for (uint32_t s = 0; s < kMaxChildren; ++s) {
      if (kidOfSlot[s] < 0) continue;
      const Child8& k = kids[size_t(kidOfSlot[s])];
      uint32_t meta;
      if (k.leaf()) {
        meta = (((1u << k.count) - 1u) << 5) | offset;
        for (uint32_t i = 0; i < k.count; ++i) {
          const FlatTriangle& t = tris[k.prims[i]];
          uint32_t flags =
              (i + 1 == k.count ? MIRAGE_RT_BVH_LAST : 0u) | (t.seeThrough ? MIRAGE_RT_BVH_SEE_THROUGH : 0u);
          out.triangles.push_back({t.v[0], t.id, t.v[1], flags, t.v[2], 0u});
        }
        offset += k.count;
      } else {
        meta = MIRAGE_RT_BVH8_INNER_META + s;
        n.exponents |= 1u << (24 + s);
        inner.push_back(&k);
      }
      n.meta[s / 4] |= meta << (8 * (s % 4));
      const glm::vec3 klo = k.lo, khi = k.hi;
      uint32_t* loQ[3] = {n.loX, n.loY, n.loZ};
      uint32_t* hiQ[3] = {n.hiX, n.hiY, n.hiZ};
      for (int a = 0; a < 3; ++a) {
        // Rounded outwards, then checked exactly (double holds origin + q * 2^e exactly).
        const double step = std::ldexp(1.0, e[a]), origin = double(lo[a]);
        double qlo = std::clamp(std::floor((double(klo[a]) - origin) / step), 0.0, 255.0);
        double qhi = std::clamp(std::ceil((double(khi[a]) - origin) / step), 0.0, 255.0);
        while (qlo > 0.0 && origin + qlo * step > double(klo[a])) qlo -= 1.0;
        while (qhi < 255.0 && origin + qhi * step < double(khi[a])) qhi += 1.0;
        loQ[a][s / 4] |= uint32_t(qlo) << (8 * (s % 4));
        hiQ[a][s / 4] |= uint32_t(qhi) << (8 * (s % 4));
      }
    }
    out.nodes8[index] = n;
    out.nodes8.resize(out.nodes8.size() + inner.size()); // the inner children, consecutive
    for (size_t i = 0; i < inner.size(); ++i) place(*inner[i], n.childBase + uint32_t(i), depth + 1);
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
  const bool wide = options.width == 4, compressed = options.width == 8;
  args.maxBranchingFactor = compressed ? 8 : wide ? 4 : 2;
  // The shader's stack holds a sentinel and what each level pushes: one entry (binary), three
  // (4-wide); 8-wide pushes one node group per level, plus up to 4 levels for forced long leaves
  // split into nodes of leaves (32 triangles: 3 x 8 x 8 fit in two).
  args.maxDepth = compressed ? MIRAGE_RT_BVH8_STACK - 4
                  : wide     ? (MIRAGE_RT_BVH_STACK - 2) / 3
                             : MIRAGE_RT_BVH_STACK - 2;
  args.minLeafSize = 1;
  args.maxLeafSize = std::clamp(options.maxLeafSize, 1u, uint32_t(RTC_BUILD_MAX_PRIMITIVES_PER_LEAF));
  if (compressed) args.maxLeafSize = std::min(args.maxLeafSize, MIRAGE_RT_BVH8_LEAF_MAX);
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
  if (compressed) {
    // The root is node 0 even when the whole scene is one leaf (then a node with one leaf slot).
    Layout8 layout8{tris, extent * 0x1p-21f, out};
    out.nodes8.reserve(tris.size() / 4);
    out.triangles.reserve(tris.size() * 3 / 2);
    out.nodes8.resize(1);
    Child8 top{sceneLo, sceneHi};
    RTCBounds all{sceneLo.x, sceneLo.y, sceneLo.z, 0, sceneHi.x, sceneHi.y, sceneHi.z, 0};
    if (root->leaf) {
      BuildNode wrap;
      wrap.count = 1;
      wrap.child[0] = root;
      wrap.bounds[0] = all;
      top.node = &wrap;
      layout8.place(top, 0, 1);
    } else {
      top.node = root;
      layout8.place(top, 0, 1);
    }
  } else if (wide)
    out.nodes4.reserve(tris.size() / 2);
  else
    out.nodes.reserve(tris.size());
  out.triangles.reserve(tris.size() * 3 / 2);
  if (root->leaf && !compressed) { // a root inner node whose only child is the one leaf
    BuildNode top;
    top.count = 1;
    top.child[0] = root;
    top.bounds[0] = {sceneLo.x, sceneLo.y, sceneLo.z, 0, sceneHi.x, sceneHi.y, sceneHi.z, 0};
    layout.place(&top, 0);
  } else if (!compressed) {
    layout.place(root, 0);
  }
  rtcReleaseBVH(bvh); // frees the builder's tree
  rtcReleaseDevice(device);
  if (out.triangles.size() >= MIRAGE_RT_BVH_LEAF ||
      std::max({out.nodes.size(), out.nodes4.size(), out.nodes8.size()}) >= MIRAGE_RT_BVH_NONE)
    return makeError(scene.source, "compute BVH: more than 2^31 triangle references");
  out.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void decodeBvh8Box(const shaderio::RtBvh8Node& node, uint32_t slot, glm::dvec3& lo, glm::dvec3& hi) {
  const uint32_t* loQ[3] = {node.loX, node.loY, node.loZ};
  const uint32_t* hiQ[3] = {node.hiX, node.hiY, node.hiZ};
  for (int a = 0; a < 3; ++a) {
    const double step = std::ldexp(1.0, int((node.exponents >> (8 * a)) & 0xffu) - 127);
    const uint32_t shift = 8 * (slot % 4);
    lo[a] = double(node.origin[a]) + double((loQ[a][slot / 4] >> shift) & 0xffu) * step;
    hi[a] = double(node.origin[a]) + double((hiQ[a][slot / 4] >> shift) & 0xffu) * step;
  }
}

namespace {

float safeInverse(float d) { return 1.0f / (std::abs(d) > 1e-20f ? d : (d >= 0.0f ? 1e-20f : -1e-20f)); }

struct CpuRay {
  glm::vec3 origin, dir, idir, ood;
  float tnear, tbest;
};

// The shaders' slab test of one box: its entry distance, or +inf.
float enterBox(const CpuRay& r, glm::vec3 lo, glm::vec3 hi) {
  float entry = r.tnear, exit = r.tbest;
  for (int a = 0; a < 3; ++a) {
    float t0 = std::fma(lo[a], r.idir[a], -r.ood[a]), t1 = std::fma(hi[a], r.idir[a], -r.ood[a]);
    entry = std::max(entry, std::min(t0, t1));
    exit = std::min(exit, std::max(t0, t1));
  }
  return entry <= exit ? entry : INFINITY;
}

// The shaders' Moller-Trumbore test, both faces; updates the result as the shaders do.
void testTriangle(const shaderio::RtBvhTriangle& tri, CpuRay& r, CpuTraceResult& out, float& seeThroughT) {
  ++out.triangleTests;
  glm::vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0, pv = glm::cross(r.dir, e2);
  float inv = 1.0f / glm::dot(e1, pv);
  glm::vec3 s = r.origin - tri.v0;
  float u = glm::dot(s, pv) * inv;
  glm::vec3 q = glm::cross(s, e1);
  float v = glm::dot(r.dir, q) * inv, t = glm::dot(e2, q) * inv;
  if (!(u >= 0.0f && v >= 0.0f && u + v <= 1.0f && t >= r.tnear && t < r.tbest)) return;
  if (tri.flags & MIRAGE_RT_BVH_SEE_THROUGH) {
    if (t < seeThroughT) {
      seeThroughT = t;
      out.seeThrough = tri.id;
    }
    return;
  }
  r.tbest = t;
  out.triangle = tri.id;
  out.t = t;
}

void trace4(const RayBvh& bvh, CpuRay& r, CpuTraceResult& out, float& seeThroughT) {
  std::vector<uint32_t> stack{0u};
  while (!stack.empty()) {
    uint32_t ref = stack.back();
    stack.pop_back();
    if (ref & MIRAGE_RT_BVH_LEAF) {
      for (uint32_t k = ref & ~MIRAGE_RT_BVH_LEAF;; ++k) {
        testTriangle(bvh.triangles[k], r, out, seeThroughT);
        if (bvh.triangles[k].flags & MIRAGE_RT_BVH_LAST) break;
      }
      continue;
    }
    ++out.nodes;
    const shaderio::RtBvh4Node& n = bvh.nodes4[ref];
    std::array<std::pair<float, uint32_t>, 4> hits;
    int count = 0;
    for (int c = 0; c < 4; ++c) {
      if (n.child[c] == MIRAGE_RT_BVH_NONE) continue;
      float e = enterBox(r, {n.loX[c], n.loY[c], n.loZ[c]}, {n.hiX[c], n.hiY[c], n.hiZ[c]});
      if (e < INFINITY) hits[size_t(count++)] = {e, n.child[c]};
    }
    std::sort(hits.begin(), hits.begin() + count); // nearest visited first: pushed last
    for (int i = count - 1; i >= 0; --i) stack.push_back(hits[size_t(i)].second);
  }
}

// The 8-wide traversal of vis_trace_bvh8.glsl: node groups (child base, hit bits | imask).
void trace8(const RayBvh& bvh, CpuRay& r, CpuTraceResult& out, float& seeThroughT) {
  const uint32_t octant = (r.dir.x < 0.0f ? 1u : 0u) | (r.dir.y < 0.0f ? 2u : 0u) | (r.dir.z < 0.0f ? 4u : 0u);
  const uint32_t octinv = 7u - octant;
  std::vector<std::pair<uint32_t, uint32_t>> stack;
  std::pair<uint32_t, uint32_t> group{0u, 0x80000000u}; // the root: one inner child at the top bit
  for (;;) {
    const uint32_t bit = 31u - uint32_t(std::countl_zero(group.second));
    group.second &= ~(1u << bit);
    const uint32_t slot = (bit - 24u) ^ octinv;
    const uint32_t index = group.first + uint32_t(std::popcount(group.second & 0xffu & ((1u << slot) - 1u)));
    if (group.second > 0x00ffffffu) stack.push_back(group);
    ++out.nodes;
    const shaderio::RtBvh8Node& n = bvh.nodes8[index];
    uint32_t hitMask = 0;
    for (uint32_t s = 0; s < 8; ++s) {
      uint32_t meta = (n.meta[s / 4] >> (8 * (s % 4))) & 0xffu;
      if (meta == 0) continue;
      glm::dvec3 lo, hi;
      decodeBvh8Box(n, s, lo, hi);
      if (enterBox(r, glm::vec3(lo), glm::vec3(hi)) == INFINITY) continue;
      uint32_t index5 = meta & 31u;
      if (index5 >= 24u) index5 = 24u + ((index5 - 24u) ^ octinv);
      hitMask |= (meta >> 5) << index5;
    }
    group = {n.childBase, (hitMask & 0xff000000u) | (n.exponents >> 24)};
    for (uint32_t tris = hitMask & 0x00ffffffu; tris != 0; tris &= tris - 1)
      testTriangle(bvh.triangles[n.triangleBase + uint32_t(std::countr_zero(tris))], r, out, seeThroughT);
    if (group.second <= 0x00ffffffu) {
      if (stack.empty()) break;
      group = stack.back();
      stack.pop_back();
    }
  }
}

} // namespace

CpuTraceResult cpuTrace(const RayBvh& bvh, glm::vec3 origin, glm::vec3 dir, float tnear, float tfar) {
  CpuTraceResult out;
  CpuRay r{origin, dir,   {safeInverse(dir.x), safeInverse(dir.y), safeInverse(dir.z)},
           {},     tnear, std::min(tfar, 3.4e38f)};
  r.ood = r.origin * r.idir;
  out.t = tfar;
  float seeThroughT = INFINITY;
  if (!bvh.nodes8.empty())
    trace8(bvh, r, out, seeThroughT);
  else if (!bvh.nodes4.empty())
    trace4(bvh, r, out, seeThroughT);
  if (out.seeThrough != MIRAGE_RT_NO_HIT && out.triangle != MIRAGE_RT_NO_HIT && seeThroughT >= out.t)
    out.seeThrough = MIRAGE_RT_NO_HIT;
  return out;
}

} // namespace mirage::vis::detail
