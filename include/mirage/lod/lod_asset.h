#pragma once
// A baked cluster-LOD scene in a .mrg file: the scene (instances, materials, textures; mesh
// geometry stripped, since each mesh's DAG holds it) in a 'SCEN' chunk, one 'CDAG' chunk per mesh
// in mesh order, a 'TMAP' chunk mapping every mesh's source triangles to level-0 clusters (how a
// triangle PVS of the source scene becomes a cluster PVS, cluster_pvs.h), and a 'META' JSON chunk
// with the build settings and statistics.
#include <functional>
#include <string>
#include <vector>

#include "mirage/asset/source.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/paging.h"

namespace mirage::lod {

struct LodAsset {
  Scene scene;                  // meshes keep name, material and bounds; geometry lives in dags
  std::vector<ClusterDag> dags; // one per scene mesh
  std::string metaJson;         // build settings and statistics as written
  // Per mesh, per source triangle (the input mesh's index order): the level-0 cluster holding it,
  // or kNone for a degenerate one (dropped by the builder). A dropped duplicate maps to the cluster
  // of the copy that was kept. Empty for assets baked before the map was recorded.
  std::vector<std::vector<uint32_t>> sourceClusters;
};

inline constexpr uint32_t kSourceMapVersion = 1;

// The source-triangle map of one mesh and its DAG (see LodAsset::sourceClusters), found by
// matching each source triangle's three welded positions (either winding) against the level-0
// clusters' triangles: the builder only welds, drops degenerate and duplicate triangles and
// reorders, so every other source triangle has exactly that triple in level 0.
std::vector<uint32_t> sourceTriangleClusters(const Mesh& mesh, const ClusterDag& dag);

// Progress callback: (meshes done, mesh count, input triangles done, total input triangles).
using BuildProgress = std::function<void(size_t, size_t, uint64_t, uint64_t)>;

// Builds a DAG for every mesh of `scene` (instances are kept as instances: each unique mesh is
// baked once). Errors name the mesh. The same as bakeLodMesh on every mesh, then assembleLodAsset.
Result<LodAsset> bakeLodAsset(const Scene& scene, const BuildConfig& config, const BuildProgress& progress = {});

// One mesh's share of a bake, independent of every other mesh and of config.threads (bit for bit):
// the work unit of a distributed bake (docs/bake.md), carried between processes by baked_mesh.h.
struct BakedMesh {
  ClusterDag dag;
  std::vector<uint32_t> sourceClusters; // LodAsset::sourceClusters of this mesh
};
// `where` names the mesh in errors (meshWhere: "scene.glb: mesh 3 'door'").
Result<BakedMesh> bakeLodMesh(const Mesh& mesh, const std::string& where, const BuildConfig& config);
std::string meshWhere(const Scene& scene, size_t mesh);
// The asset of `scene` from one BakedMesh per scene mesh, in mesh order (bakeLodAsset's result).
LodAsset assembleLodAsset(const Scene& scene, const BuildConfig& config, std::vector<BakedMesh> meshes);

struct LodWriteOptions {
  DagEncodeOptions dag; // positionBits also sets the pages' grid (the same grid either way)
  // Paged: each mesh's DAG as a 'CPAG' chunk (paged_asset.h: page table, one block per page) instead
  // of a 'CDAG' chunk; a paged file holds no CDAG (loaders reassemble the DAG from the pages). Off by
  // default: the dragon's file grows from 10.5 to 15.4 MB (docs/lod.md, "Paged chunk"), and only a
  // reader that loads pages on demand gains from them. `mirage build --paged`, `--page-size BYTES`.
  bool paged = false;
  PageConfig pages; // page budget (pageBytes); positionBits is taken from `dag`
  // Threads encoding and compressing the meshes' chunks, one mesh each (0 = all cores). The bytes
  // do not depend on it.
  uint32_t threads = 0;
};

Status saveLodAsset(const std::string& path, const LodAsset& asset, const LodWriteOptions& options = {});
// Validates the container, every chunk, and that there is one DAG per mesh: a 'CDAG' chunk per
// mesh or, in a paged file without CDAG chunks, a 'CPAG' chunk per mesh, every page read and
// checked and the DAG reassembled (reassemblePagedDag).
Result<LodAsset> loadLodAsset(const std::string& path, const asset::SourceOptions& options = {});

// The mesh the DAG's level-0 clusters cover (cleaned input, positions as stored): the reference
// for cut checks on a loaded asset.
Mesh levelZeroMesh(const ClusterDag& dag);
// The asset's scene with every mesh replaced by its level-0 mesh, with the DAG's normals and UVs
// and the mesh's material: the forward renderer's full-resolution reference for LOD images.
Scene levelZeroScene(const LodAsset& asset);

// The clusters' triangles as an ordinary indexed mesh with normals and UVs, holding only the
// vertices they use: a fixed LOD (e.g. the cut selectCut gives for one object-space error), for
// renderers without cluster LOD such as the discrete-LOD baseline of `mirage bench render`.
Mesh cutMesh(const ClusterDag& dag, const std::vector<uint32_t>& clusters);

} // namespace mirage::lod
