#include "mirage/lod/baked_mesh.h"

#include "mirage/asset/bytes.h"
#include "mirage/lod/verify.h"

namespace mirage::lod {

namespace {

constexpr uint32_t kBakedMeshMagic = 0x4d4b4142; // "BAKM"
// Cluster and Group are copied whole: they must stay free of padding (indeterminate bytes).
static_assert(sizeof(Cluster) == 5 * 4 + 2 * 2 + 3 * sizeof(LodBounds));
static_assert(sizeof(Group) == 5 * 4 + sizeof(LodBounds) + 4);
static_assert(sizeof(LodBounds) == 5 * 4);

} // namespace

std::vector<uint8_t> encodeBakedMesh(const BakedMesh& mesh) {
  const ClusterDag& d = mesh.dag;
  asset::ByteWriter w;
  w.reserve(d.positions.size() * 12 + d.vertexPosition.size() * 4 + d.normals.size() * 12 + d.uv0.size() * 8 +
            d.clusters.size() * sizeof(Cluster) + d.clusterVertices.size() * 4 + d.clusterIndices.size() +
            d.groups.size() * sizeof(Group) + (d.groupChildren.size() + d.groupParents.size()) * 4 +
            mesh.sourceClusters.size() * 4 + 256);
  w.write(kBakedMeshMagic);
  w.writeArray(std::span<const glm::vec3>(d.positions));
  w.writeArray(std::span<const uint32_t>(d.vertexPosition));
  w.writeArray(std::span<const glm::vec3>(d.normals));
  w.writeArray(std::span<const glm::vec2>(d.uv0));
  w.writeArray(std::span<const Cluster>(d.clusters));
  w.writeArray(std::span<const uint32_t>(d.clusterVertices));
  w.writeArray(std::span<const uint8_t>(d.clusterIndices));
  w.writeArray(std::span<const Group>(d.groups));
  w.writeArray(std::span<const uint32_t>(d.groupChildren));
  w.writeArray(std::span<const uint32_t>(d.groupParents));
  w.writeArray(std::span<const uint32_t>(d.roots));
  w.writeVarint(d.levels.size());
  for (const LevelStats& l : d.levels) { // field by field: LevelStats has padding
    w.write(l.clusters), w.write(l.triangles), w.write(l.meanFill), w.write(l.groups), w.write(l.stuckGroups);
    w.write(l.meanEdgeAge), w.write(l.seconds);
  }
  w.write(d.inputTriangles);
  w.writeArray(std::span<const uint32_t>(mesh.sourceClusters));
  return w.take();
}

Result<BakedMesh> decodeBakedMesh(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  BakedMesh mesh;
  ClusterDag& d = mesh.dag;
  uint32_t magic = 0;
  if (!r.read(magic)) return r.error();
  if (magic != kBakedMeshMagic) return makeError(where, "not a baked mesh");
  r.readArray(d.positions), r.readArray(d.vertexPosition), r.readArray(d.normals), r.readArray(d.uv0);
  r.readArray(d.clusters), r.readArray(d.clusterVertices), r.readArray(d.clusterIndices), r.readArray(d.groups);
  r.readArray(d.groupChildren), r.readArray(d.groupParents), r.readArray(d.roots);
  uint64_t levels = 0;
  if (!r.readCount(levels, r.remaining() / 32, "level count")) return r.error();
  d.levels.resize(levels);
  for (LevelStats& l : d.levels) {
    r.read(l.clusters), r.read(l.triangles), r.read(l.meanFill), r.read(l.groups), r.read(l.stuckGroups);
    r.read(l.meanEdgeAge), r.read(l.seconds);
  }
  r.read(d.inputTriangles);
  r.readArray(mesh.sourceClusters);
  if (Status s = r.finish(); !s) return s.error();
  bool attributesFit = (d.normals.empty() || d.normals.size() == d.vertexPosition.size()) &&
                       (d.uv0.empty() || d.uv0.size() == d.vertexPosition.size());
  if (!attributesFit || d.clusters.empty() || d.clusterIndices.size() % 3)
    return makeError(where, "baked mesh arrays do not fit together");
  if (Status s = checkDagStructure(d); !s) return makeError(where, "baked mesh: " + s.error().message);
  for (uint32_t c : mesh.sourceClusters)
    if (c != kNone && (c >= d.clusters.size() || d.clusters[c].level != 0))
      return makeError(where, "baked mesh: source map names a bad cluster");
  return mesh;
}

std::vector<uint8_t> encodeMeshUnit(const Scene& scene, size_t mesh) {
  const Mesh& m = scene.meshes[mesh];
  asset::ByteWriter w;
  w.reserve(m.positions.size() * 12 + m.normals.size() * 12 + m.uv0.size() * 8 + m.indices.size() * 4 + 256);
  w.writeString(meshWhere(scene, mesh));
  w.writeString(m.name);
  w.writeArray(std::span<const glm::vec3>(m.positions));
  w.writeArray(std::span<const glm::vec3>(m.normals));
  w.writeArray(std::span<const glm::vec2>(m.uv0));
  w.writeArray(std::span<const uint32_t>(m.indices));
  return w.take();
}

Result<BakedMesh> bakeMeshUnit(std::span<const uint8_t> unit, const BuildConfig& config) {
  asset::ByteReader r(unit, "mesh unit");
  std::string where;
  Mesh m;
  r.readString(where), r.readString(m.name);
  r.readArray(m.positions), r.readArray(m.normals), r.readArray(m.uv0), r.readArray(m.indices);
  if (Status s = r.finish(); !s) return s.error();
  return bakeLodMesh(m, where, config);
}

} // namespace mirage::lod
