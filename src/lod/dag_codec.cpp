#include "mirage/lod/dag_codec.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mirage/asset/bytes.h"
#include "mirage/core/octahedral.h"
#include "mirage/lod/verify.h"

#include "codec_common.h"

namespace mirage::lod {

using asset::ByteReader;
using asset::ByteWriter;

using detail::PackedAttributes;
using detail::PackedPosition;
using detail::PositionGrid;
using detail::readIds;
using detail::readSphere;
using detail::readVertexStream;
using detail::writeIds;
using detail::writeSphere;
using detail::writeVertexStream;

std::vector<uint8_t> encodeDag(const ClusterDag& dag, const DagEncodeOptions& options) {
  ByteWriter w;
  w.reserve(dag.clusterIndices.size() * 2 + dag.positions.size() * 8);
  w.write(kDagCodecVersion);
  w.write(uint64_t(dag.inputTriangles));

  std::vector<PackedPosition> packed;
  PositionGrid grid = detail::choosePositionGrid(dag.positions, options.positionBits, packed);
  detail::writeGrid(w, grid);
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
    w.write(l.meanEdgeAge), w.write(0.0f); // LevelStats::seconds: timings stay out of the file
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
  PositionGrid grid;
  r.read(inputTriangles), detail::readGrid(r, grid);
  if (!r.ok()) return r.error();
  if (!detail::gridValid(grid)) return makeError(file, "bad position quantization");
  dag.inputTriangles = inputTriangles;

  // Every count is bounded by the bytes that remain, so corrupt counts cannot allocate much: an
  // encoded element takes at least one byte (vertex codec streams at least 1/16 byte per byte of
  // output, hence the factor for streams).
  uint64_t positionCount = 0;
  if (!r.readCount(positionCount, r.remaining() * 16, "position count")) return r.error();
  std::vector<PackedPosition> packed(positionCount);
  if (!readVertexStream(r, bytes, packed.data(), packed.size(), sizeof(PackedPosition))) return r.error();
  dag.positions.resize(positionCount);
  for (size_t i = 0; i < packed.size(); ++i) {
    if (!detail::packedValid(grid, packed[i]))
      return makeError(file, grid.raw() ? "non-finite position" : "position off the grid");
    dag.positions[i] = detail::unpackPosition(grid, packed[i]);
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
  float slack = detail::positionSlack(grid);
  // Every path that loads a DAG (render, info, verify) gets the same structural checks here, before
  // anything indexes with what was decoded.
  if (Status s = checkDagStructure(dag); !s) return makeError(file, s.error().message);
  for (Group& g : dag.groups) g.bounds = detail::widenGroupBounds(g.bounds, g.level, slack);
  for (size_t i = 0; i < dag.clusters.size(); ++i) {
    Cluster& c = dag.clusters[i];
    c.bounds.radius = detail::widenClusterRadius(c.bounds.radius, slack);
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
