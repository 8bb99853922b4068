#include "mirage/lod/dag_codec.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <tuple>

#include <meshoptimizer.h>

#include "mirage/asset/bytes.h"
#include "mirage/core/octahedral.h"
#include "mirage/lod/verify.h"

namespace mirage::lod {

using asset::ByteReader;
using asset::ByteWriter;

namespace {

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }
int64_t unzigzag(uint64_t v) { return int64_t(v >> 1) ^ -int64_t(v & 1); }

// Ids in order, each as the zigzag delta from the previous one: ids of neighbouring clusters and
// vertices are close, so most take one byte.
void writeIds(ByteWriter& w, std::span<const uint32_t> ids) {
  w.writeVarint(ids.size());
  int64_t prev = 0;
  for (uint32_t id : ids) {
    w.writeVarint(zigzag(int64_t(id) - prev));
    prev = id;
  }
}

bool readIds(ByteReader& r, std::vector<uint32_t>& out, uint64_t limit, const char* what) {
  uint64_t n = 0;
  if (!r.readCount(n, std::min<uint64_t>(limit, r.remaining()), what)) return false;
  out.resize(n);
  int64_t prev = 0;
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t z = 0;
    if (!r.readVarint(z)) return false;
    int64_t v = prev + unzigzag(z);
    if (v < 0 || v > int64_t(UINT32_MAX)) return r.fail(std::string(what) + " id out of range");
    out[i] = uint32_t(v);
    prev = v;
  }
  return true;
}

// meshopt's vertex codec over fixed-size records; the encoded size goes first.
void writeVertexStream(ByteWriter& w, const void* vertices, size_t count, size_t stride) {
  std::vector<uint8_t> buffer(meshopt_encodeVertexBufferBound(count, stride));
  buffer.resize(meshopt_encodeVertexBuffer(buffer.data(), buffer.size(), vertices, count, stride));
  w.writeVarint(buffer.size());
  w.writeBytes(buffer);
}

bool readVertexStream(ByteReader& r, std::span<const uint8_t> all, void* out, size_t count, size_t stride) {
  uint64_t size = 0;
  if (!r.readCount(size, r.remaining(), "vertex stream size")) return false;
  const uint8_t* data = all.data() + r.position();
  if (!r.skip(size)) return false;
  if (meshopt_decodeVertexBuffer(out, count, stride, data, size) != 0) return r.fail("corrupt vertex stream");
  return true;
}

struct Quantizer {
  glm::vec3 origin{0.0f};
  float step = 1.0f;
};

// Raw float positions (no grid): stored in the bits field.
constexpr uint32_t kRawPositionBits = 32;
constexpr uint32_t kMaxGridBits = 24; // float holds every integer up to 2^24 exactly

struct PackedPosition {
  uint32_t x, y, z; // grid coordinates (up to 24 bits used)
};
static_assert(sizeof(PackedPosition) == 12);

struct PackedAttributes {
  uint32_t normal; // octahedral, snorm16 x (low half) and y
  float u, v;
};
static_assert(sizeof(PackedAttributes) == 12);

glm::vec3 gridPosition(const Quantizer& q, const PackedPosition& p);

// Open-addressing hash set of the decoded positions: linear time (a sort of the indices per tried
// bit count was an eighth of the whole `mirage build` of the dragon, run once per bit count
// tried). Compared as decoded floats, not grid points: far from the origin two grid points can
// round to one float.
bool positionsDistinct(const Quantizer& q, const std::vector<PackedPosition>& packed) {
  auto bitsOf = [&](uint32_t i) {
    glm::vec3 p = gridPosition(q, packed[i]) + glm::vec3(0.0f); // -0 and +0 are one position
    std::array<uint32_t, 3> b;
    std::memcpy(b.data(), &p, sizeof(p));
    return b;
  };
  size_t size = 16;
  while (size < packed.size() * 2) size *= 2;
  std::vector<uint32_t> slots(size, ~0u);
  for (uint32_t i = 0; i < packed.size(); ++i) {
    std::array<uint32_t, 3> p = bitsOf(i);
    uint64_t h = (uint64_t(p[0]) * 0x9e3779b97f4a7c15ull) ^ (uint64_t(p[1]) * 0xc2b2ae3d27d4eb4full) ^
                 (uint64_t(p[2]) * 0x165667b19e3779f9ull);
    h ^= h >> 29;
    for (size_t s = size_t(h) & (size - 1);; s = (s + 1) & (size - 1)) {
      if (slots[s] == ~0u) {
        slots[s] = i;
        break;
      }
      if (bitsOf(slots[s]) == p) return false;
    }
  }
  return true;
}

// A grid point as the decoder places it (the encoder checks its choice with the same function).
glm::vec3 gridPosition(const Quantizer& q, const PackedPosition& p) {
  return q.origin + glm::vec3(float(p.x), float(p.y), float(p.z)) * q.step;
}

// How far a decoded position may be from the original: half a step per axis (sqrt(3)/2 step in
// all) plus the float rounding of the product and the sum, at most 2^-24 of the largest coordinate
// each per axis. The encoder only keeps a grid that meets it; the decoder widens every sphere and
// error by it, so culling and LOD selection stay conservative.
float positionSlack(const Quantizer& q, uint32_t bits) {
  if (bits == kRawPositionBits) return 0.0f;
  float top = q.step * float((1u << bits) - 1);
  float magnitude = std::max({std::abs(q.origin.x), std::abs(q.origin.y), std::abs(q.origin.z)}) + top;
  return q.step + std::ldexp(magnitude, -22);
}

// The grid of `bits` per axis over `box`: step = largest extent / (2^bits - 1), rounded up as a
// float so that the top coordinate lands on the last grid point, not one past it (rounded to
// nearest, the step was too small for about 10 % of boxes at 23 bits).
Quantizer makeGrid(const Bounds& box, uint32_t bits) {
  Quantizer q;
  if (box.empty()) return q;
  q.origin = box.min;
  double extent = 0.0; // in double: max - min of two floats is exact there
  for (int a = 0; a < 3; ++a) extent = std::max(extent, double(box.max[a]) - double(box.min[a]));
  double cells = double((1u << bits) - 1);
  q.step = std::max(float(extent / cells), std::numeric_limits<float>::min());
  while (double(q.step) * cells < extent) q.step = std::nextafter(q.step, std::numeric_limits<float>::infinity());
  return q;
}

// Quantizes `positions` on `q`, true when the result decodes within positionSlack of every
// original and keeps distinct positions distinct (fused ones would change the topology).
bool quantize(const std::vector<glm::vec3>& positions, const Quantizer& q, uint32_t bits,
              std::vector<PackedPosition>& packed) {
  double maxGrid = double((1u << bits) - 1);
  float slack = positionSlack(q, bits);
  if (!std::isfinite(slack)) return false; // coordinates near the float range: the decoder would refuse it
  for (size_t i = 0; i < positions.size(); ++i) {
    uint32_t g[3];
    for (int a = 0; a < 3; ++a) {
      double t = (double(positions[i][a]) - double(q.origin[a])) / double(q.step);
      g[a] = uint32_t(std::clamp(std::nearbyint(t), 0.0, maxGrid));
    }
    packed[i] = {g[0], g[1], g[2]};
    if (!(glm::distance(gridPosition(q, packed[i]), positions[i]) <= slack)) return false;
  }
  return positionsDistinct(q, packed);
}

void writeSphere(ByteWriter& w, const LodBounds& b) {
  w.write(b.center.x), w.write(b.center.y), w.write(b.center.z), w.write(b.radius);
}
bool readSphere(ByteReader& r, LodBounds& b) {
  return r.read(b.center.x) && r.read(b.center.y) && r.read(b.center.z) && r.read(b.radius);
}

} // namespace

std::vector<uint8_t> encodeDag(const ClusterDag& dag, const DagEncodeOptions& options) {
  ByteWriter w;
  w.reserve(dag.clusterIndices.size() * 2 + dag.positions.size() * 8);
  w.write(kDagCodecVersion);
  w.write(uint64_t(dag.inputTriangles));

  // Positions on a grid over the bounds. Distinct welded positions must stay distinct, or the
  // decoded mesh would change topology (two vertices fused into one): take more bits until none
  // collide.
  Bounds box;
  for (const glm::vec3& p : dag.positions) box.add(p);
  uint32_t bits = options.positionBits > kMaxGridBits ? kRawPositionBits : std::max(options.positionBits, 8u);
  Quantizer q;
  std::vector<PackedPosition> packed(dag.positions.size());
  for (; bits <= kMaxGridBits; ++bits) {
    q = makeGrid(box, bits);
    if (quantize(dag.positions, q, bits, packed)) break;
  }
  if (bits > kMaxGridBits) {
    // Vertices closer than 1/2^24 of the extent but not equal (float noise in the source), or a
    // mesh so far from the origin that float rounding of the grid exceeds its step: only the
    // exact floats keep them. bits = 32 marks raw float positions.
    bits = kRawPositionBits;
    q = Quantizer{};
    static_assert(sizeof(PackedPosition) == sizeof(glm::vec3));
    std::memcpy(packed.data(), dag.positions.data(), packed.size() * sizeof(glm::vec3));
  }
  w.write(bits);
  w.write(q.origin.x), w.write(q.origin.y), w.write(q.origin.z), w.write(q.step);
  w.writeVarint(packed.size());
  writeVertexStream(w, packed.data(), packed.size(), sizeof(PackedPosition));

  // Attribute vertices: their welded position, normal and uv.
  w.writeVarint(dag.vertexPosition.size());
  writeIds(w, dag.vertexPosition);
  uint8_t flags = uint8_t((dag.normals.empty() ? 0 : 1) | (dag.uv0.empty() ? 0 : 2));
  w.write(flags);
  if (flags) {
    std::vector<PackedAttributes> attrs(dag.vertexPosition.size());
    for (size_t i = 0; i < attrs.size(); ++i) {
      uint32_t n = dag.normals.empty() ? 0u : encodeOctahedral(dag.normals[i]);
      attrs[i] = {n, dag.uv0.empty() ? 0.0f : dag.uv0[i].x, dag.uv0.empty() ? 0.0f : dag.uv0[i].y};
    }
    writeVertexStream(w, attrs.data(), attrs.size(), sizeof(PackedAttributes));
  }

  // Clusters: sizes, level and group links; offsets are implied by the order.
  w.writeVarint(dag.clusters.size());
  for (const Cluster& c : dag.clusters) {
    w.writeVarint(c.vertexCount);
    w.writeVarint(c.triangleCount);
    w.writeVarint(c.level);
    w.writeVarint(uint32_t(c.generatingGroup + 1)); // kNone + 1 wraps to 0 in 32 bits
    w.writeVarint(uint32_t(c.group + 1));
    writeSphere(w, c.bounds);
  }
  writeIds(w, dag.clusterVertices);
  w.writeArray(std::span<const uint8_t>(dag.clusterIndices));

  w.writeVarint(dag.groups.size());
  for (const Group& g : dag.groups) {
    w.writeVarint(g.level);
    w.writeVarint(g.childCount);
    w.writeVarint(g.parentCount);
    writeSphere(w, g.bounds);
    w.write(g.bounds.error);
    w.write(g.simplifyError);
  }
  writeIds(w, dag.groupChildren);
  writeIds(w, dag.groupParents);
  writeIds(w, dag.roots);

  w.writeVarint(dag.levels.size());
  for (const LevelStats& l : dag.levels) {
    w.write(l.clusters), w.write(l.triangles), w.write(l.meanFill), w.write(l.groups), w.write(l.stuckGroups);
    w.write(l.meanEdgeAge), w.write(l.seconds);
  }
  return w.take();
}

Result<ClusterDag> decodeDag(std::span<const uint8_t> bytes, const std::string& file) {
  ByteReader r(bytes, file);
  ClusterDag dag;
  uint32_t version = 0;
  if (!r.read(version)) return r.error();
  if (version != kDagCodecVersion)
    return makeError(file, "cluster DAG encoding version " + std::to_string(version) + " (this build reads " +
                               std::to_string(kDagCodecVersion) + ")");
  uint64_t inputTriangles = 0;
  uint32_t bits = 0;
  Quantizer q;
  r.read(inputTriangles), r.read(bits), r.read(q.origin.x), r.read(q.origin.y), r.read(q.origin.z), r.read(q.step);
  if (!r.ok()) return r.error();
  bool rawFloats = bits == kRawPositionBits;
  if (!rawFloats &&
      (bits < 8 || bits > kMaxGridBits || !(q.step > 0.0f) || !std::isfinite(q.step) || !std::isfinite(q.origin.x) ||
       !std::isfinite(q.origin.y) || !std::isfinite(q.origin.z) || !std::isfinite(positionSlack(q, bits))))
    return makeError(file, "bad position quantization");
  dag.inputTriangles = inputTriangles;

  // Every count is bounded by the bytes that remain, so corrupt counts cannot allocate much: an
  // encoded element takes at least one byte (vertex codec streams at least 1/16 byte per byte of
  // output, hence the factor for streams).
  uint64_t positionCount = 0;
  if (!r.readCount(positionCount, r.remaining() * 16, "position count")) return r.error();
  std::vector<PackedPosition> packed(positionCount);
  if (!readVertexStream(r, bytes, packed.data(), packed.size(), sizeof(PackedPosition))) return r.error();
  dag.positions.resize(positionCount);
  uint32_t maxGrid = rawFloats ? 0 : (1u << bits) - 1;
  if (rawFloats) {
    std::memcpy(dag.positions.data(), packed.data(), packed.size() * sizeof(glm::vec3));
    for (const glm::vec3& p : dag.positions)
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return makeError(file, "non-finite position");
  }
  for (size_t i = 0; i < packed.size() && !rawFloats; ++i) {
    if (packed[i].x > maxGrid || packed[i].y > maxGrid || packed[i].z > maxGrid)
      return makeError(file, "position off the grid");
    dag.positions[i] = gridPosition(q, packed[i]);
  }

  uint64_t vertexCount = 0;
  if (!r.readCount(vertexCount, r.remaining(), "vertex count")) return r.error();
  if (!readIds(r, dag.vertexPosition, vertexCount, "vertex position")) return r.error();
  if (dag.vertexPosition.size() != vertexCount) return makeError(file, "vertex count mismatch");
  for (uint32_t p : dag.vertexPosition)
    if (p >= positionCount) return makeError(file, "vertex refers to a missing position");
  uint8_t flags = 0;
  if (!r.read(flags)) return r.error();
  if (flags > 3) return makeError(file, "unknown attribute flags");
  if (flags) {
    std::vector<PackedAttributes> attrs(vertexCount);
    if (!readVertexStream(r, bytes, attrs.data(), attrs.size(), sizeof(PackedAttributes))) return r.error();
    if (flags & 1) dag.normals.resize(vertexCount);
    if (flags & 2) dag.uv0.resize(vertexCount);
    for (size_t i = 0; i < attrs.size(); ++i) {
      if (flags & 1) dag.normals[i] = decodeOctahedral(attrs[i].normal);
      if (flags & 2) dag.uv0[i] = {attrs[i].u, attrs[i].v};
    }
  }

  uint64_t clusterCount = 0;
  if (!r.readCount(clusterCount, r.remaining() / 21, "cluster count")) return r.error();
  dag.clusters.resize(clusterCount);
  uint64_t vertexTotal = 0, triangleTotal = 0;
  for (Cluster& c : dag.clusters) {
    uint64_t vc = 0, tc = 0, level = 0, gg = 0, g = 0;
    if (!r.readCount(vc, 255, "cluster vertex count") || !r.readCount(tc, 512, "cluster triangle count") ||
        !r.readCount(level, 64, "cluster level") || !r.readCount(gg, UINT32_MAX, "generating group") ||
        !r.readCount(g, UINT32_MAX, "group") || !readSphere(r, c.bounds))
      return r.error();
    c.vertexOffset = uint32_t(vertexTotal);
    c.triangleOffset = uint32_t(triangleTotal);
    c.vertexCount = uint16_t(vc);
    c.triangleCount = uint16_t(tc);
    c.level = uint32_t(level);
    c.generatingGroup = uint32_t(gg - 1); // 0 -> kNone
    c.group = uint32_t(g - 1);
    vertexTotal += vc;
    triangleTotal += tc;
    if (vertexTotal > UINT32_MAX || triangleTotal > UINT32_MAX / 3) return makeError(file, "cluster ranges overflow");
  }
  if (!readIds(r, dag.clusterVertices, vertexTotal, "cluster vertex")) return r.error();
  if (dag.clusterVertices.size() != vertexTotal) return makeError(file, "cluster vertex list size mismatch");
  for (uint32_t v : dag.clusterVertices)
    if (v >= vertexCount) return makeError(file, "cluster refers to a missing vertex");
  if (!r.readArray(dag.clusterIndices)) return r.error();
  if (dag.clusterIndices.size() != triangleTotal * 3) return makeError(file, "cluster index list size mismatch");

  uint64_t groupCount = 0;
  if (!r.readCount(groupCount, r.remaining() / 27, "group count")) return r.error();
  dag.groups.resize(groupCount);
  uint64_t childTotal = 0, parentTotal = 0;
  for (Group& g : dag.groups) {
    uint64_t level = 0, cc = 0, pc = 0;
    if (!r.readCount(level, 64, "group level") || !r.readCount(cc, clusterCount, "group child count") ||
        !r.readCount(pc, clusterCount, "group parent count") || !readSphere(r, g.bounds) || !r.read(g.bounds.error) ||
        !r.read(g.simplifyError))
      return r.error();
    g.level = uint32_t(level);
    g.childOffset = uint32_t(childTotal);
    g.childCount = uint32_t(cc);
    g.parentOffset = uint32_t(parentTotal);
    g.parentCount = uint32_t(pc);
    childTotal += cc;
    parentTotal += pc;
    if (childTotal > clusterCount || parentTotal > clusterCount) return makeError(file, "group ranges overflow");
  }
  if (!readIds(r, dag.groupChildren, childTotal, "group child") ||
      !readIds(r, dag.groupParents, parentTotal, "group parent") || !readIds(r, dag.roots, clusterCount, "root"))
    return r.error();
  if (dag.groupChildren.size() != childTotal || dag.groupParents.size() != parentTotal)
    return makeError(file, "group list size mismatch");
  uint64_t levelCount = 0;
  if (!r.readCount(levelCount, 64, "level count")) return r.error();
  dag.levels.resize(levelCount);
  for (LevelStats& l : dag.levels) {
    r.read(l.clusters), r.read(l.triangles), r.read(l.meanFill), r.read(l.groups), r.read(l.stuckGroups);
    r.read(l.meanEdgeAge), r.read(l.seconds);
  }
  if (Status s = r.finish(); !s) return s.error();

  // Derived LOD bounds: self = generating group's (level 0: own sphere, error 0), parent = member
  // group's (roots: +inf). Quantization moved vertices by up to positionSlack, so spheres grow by
  // that much and errors by the same distance, which keeps both conservative.
  float slack = positionSlack(q, bits);
  // Every path that loads a DAG (render, info, verify) gets the same structural checks here, before
  // anything indexes with what was decoded.
  if (Status s = checkDagStructure(dag); !s) return makeError(file, s.error().message);
  for (Group& g : dag.groups) {
    g.bounds.radius += slack * float(g.level + 2); // nested spheres stay nested level over level
    g.bounds.error += slack;
  }
  for (size_t i = 0; i < dag.clusters.size(); ++i) {
    Cluster& c = dag.clusters[i];
    c.bounds.radius += slack;
    if (c.generatingGroup == kNone) {
      c.self = c.bounds;
      c.self.error = 0.0f;
    } else {
      c.self = dag.groups[c.generatingGroup].bounds;
    }
    if (c.group == kNone) {
      c.parent = c.self;
      c.parent.error = std::numeric_limits<float>::infinity();
    } else {
      c.parent = dag.groups[c.group].bounds;
    }
  }
  return dag;
}

} // namespace mirage::lod
