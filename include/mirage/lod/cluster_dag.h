#pragma once
// Cluster-LOD DAG of one mesh (Nanite-like): level-0 clusters cover the input mesh; each group of
// clusters is simplified to about half its triangles with the group border locked and split into
// parent clusters. Plain data with flat arrays and offsets only, so the asset writer can serialize
// it chunk by chunk. Build with buildClusterDag; check with verify.h. Data flow: docs/lod.md.
#include <cstdint>
#include <limits>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/shaderio/cluster.h" // MIRAGE_CLUSTER_MAX_TRIANGLES: what the renderer draws

namespace mirage::lod {

inline constexpr uint32_t kNone = ~0u;

// Object-space LOD bounds: a sphere and the error (distance in mesh units) of the geometry it
// describes. Runtime projects `error` at the sphere's nearest point to get a screen-space error.
struct LodBounds {
  glm::vec3 center{0.0f};
  float radius = 0.0f;
  float error = 0.0f;
};

struct Cluster {
  uint32_t vertexOffset = 0;   // first entry in ClusterDag::clusterVertices
  uint32_t triangleOffset = 0; // first triangle in ClusterDag::clusterIndices (3 bytes per triangle)
  uint16_t vertexCount = 0;    // <= BuildConfig::clusterVertices (<= 255: local indices are 8-bit)
  uint16_t triangleCount = 0;  // <= BuildConfig::clusterTriangles
  uint32_t level = 0;          // 0 = input resolution
  // The group whose simplification produced this cluster (kNone at level 0). Its error and sphere
  // are this cluster's own LOD bounds: draw the cluster only when self.error <= threshold.
  uint32_t generatingGroup = kNone;
  // The group this cluster is a member of, whose output (this cluster's parents) replaces it
  // (kNone for roots). Draw the cluster only when parent.error > threshold.
  uint32_t group = kNone;
  LodBounds self;   // generating group's bounds; level 0: own bounding sphere, error 0
  LodBounds parent; // member group's bounds; roots: error = +inf
  LodBounds bounds; // tight-ish sphere of this cluster's own triangles (culling)
};

// A set of sibling clusters simplified together. Children = member clusters, parents = clusters
// built from the simplified triangles; they cover the same surface with the same outer border.
struct Group {
  uint32_t level = 0;       // level of the children
  uint32_t childOffset = 0; // range in ClusterDag::groupChildren
  uint32_t childCount = 0;
  uint32_t parentOffset = 0; // range in ClusterDag::groupParents
  uint32_t parentCount = 0;
  LodBounds bounds;           // encloses children's self spheres; error >= every child's self.error
  float simplifyError = 0.0f; // the simplifier's own error for this group (before the max with children)
};

struct LevelStats {
  uint32_t clusters = 0;
  uint64_t triangles = 0;
  float meanFill = 0.0f;    // mean triangleCount / clusterTriangles of this level's clusters
  uint32_t groups = 0;      // groups formed from this level's clusters (0 for the root level)
  uint32_t stuckGroups = 0; // groups that could not reduce enough and were regrouped later
  float meanEdgeAge = 0.0f; // mean levels a locked group-border edge of this level has stayed locked
  // Wall time to make this level's clusters: level 0 = weld, clean and split the input; level L =
  // group, simplify and split level L-1 (retries included). For `mirage bench build` breakdowns.
  float seconds = 0.0f;
};

struct ClusterDag {
  // Welded positions (exact duplicates merged): topology, cracks and simplification use these.
  std::vector<glm::vec3> positions;
  // Attribute vertices = the input mesh's vertices. Simplification only collapses vertices onto
  // existing ones, so every level reuses them: vertexPosition maps each to its welded position.
  std::vector<uint32_t> vertexPosition;
  std::vector<glm::vec3> normals; // per attribute vertex, empty when the mesh had none
  std::vector<glm::vec2> uv0;     // per attribute vertex, empty when the mesh had none

  std::vector<Cluster> clusters;         // ordered by level
  std::vector<uint32_t> clusterVertices; // attribute vertex ids, per-cluster ranges
  std::vector<uint8_t> clusterIndices;   // local 8-bit indices, 3 per triangle, per-cluster ranges
  std::vector<Group> groups;
  std::vector<uint32_t> groupChildren; // cluster ids
  std::vector<uint32_t> groupParents;  // cluster ids
  std::vector<uint32_t> roots;         // clusters without a member group (parent.error = +inf)
  std::vector<LevelStats> levels;

  uint64_t inputTriangles = 0; // triangles after dropping degenerate and duplicate ones
  uint32_t levelCount() const { return uint32_t(levels.size()); }
  uint64_t rootTriangles() const {
    uint64_t n = 0;
    for (uint32_t c : roots) n += clusters[c].triangleCount;
    return n;
  }
};

// Largest clusterTriangles: the renderer's mesh-shader output limit (shaderio/cluster.h), so every
// asset the builder writes renders. meshoptimizer would take up to 512, but with 8-bit local indices
// and <= 255 vertices more than 128 rarely fills anyway.
inline constexpr uint32_t kMaxClusterTriangles = MIRAGE_CLUSTER_MAX_TRIANGLES;

struct BuildConfig {
  // Mesh-shader friendly cluster size: a multiple of 4 (meshoptimizer) in 4..kMaxClusterTriangles.
  uint32_t clusterTriangles = 128;
  // Vertex limit per cluster (<= 255). Measured on the dragon (docs/lod.md): 64 -> 54 % mean fill,
  // 96 -> 83 %, 128 -> 91 %, 192 and 255 no better; 128 also keeps mesh-shader outputs small.
  uint32_t clusterVertices = 128;
  // Clusters per group. Measured on the dragon (docs/lod.md): 4 -> 19 levels, 84 % fill; 8 -> 12, 91 %;
  // 16 -> 11, 95 %; 32 -> 11, 97 % at equal build time. 32: fewer locked group borders per level,
  // so the cuts are closer to the input at equal triangles (LodQuality, geometric error, dragon
  // 25 / 6.2 / 1.6 %: 16 -> 6.4e-6 / 3.0e-5 / 1.3e-4, 24 -> 6.0e-6 / 2.7e-5 / 9.7e-5, 32 -> 5.8e-6 /
  // 2.6e-5 / 8.9e-5, 48 -> 5.8e-6 / 2.5e-5 / 8.7e-5), at the cost of each LOD switch covering
  // more surface.
  uint32_t groupClusters = 32;
  // Groups of clusters of this level and above hold 2 * groupClusters. Borders locked at one level
  // pile up (the dragon's mean edge age grows from 1.0 at level 0 to 3.4 at level 7), and the
  // coarse cuts pay for them: doubling from level 2 brings the dragon's 6.2 / 1.6 % cuts to
  // meshoptimizer's clusterlod (LodQuality, geometric error: 2.57e-5 / 8.90e-5 -> 2.44e-5 /
  // 8.45e-5; from level 1: 2.44e-5 / 8.46e-5, from level 3: 2.48e-5 / 8.45e-5; 48 instead of 64
  // from level 2: 2.50e-5 / 8.58e-5) while the fine levels, where LOD switches are seen up close,
  // keep groups of 32. maxLevels or more: never.
  uint32_t coarseGroupsFromLevel = 2;
  // Groups of clusters of this level and above hold 4 * groupClusters (takes precedence over
  // coarseGroupsFromLevel). The coarsest cuts are where the locked borders cost most: on the dragon
  // the 1.6 % cut drops from 8.45e-5 to 8.15e-5 (LodQuality, geometric error; clusterlod 8.44e-5)
  // with the 25 / 6.2 % cuts unchanged (from level 3: 6.2 % 2.44e-5 -> 2.38e-5, 1.6 % 8.15e-5).
  // These levels hold under 1/16 of the input's triangles: they are drawn far away, where a switch
  // covering more of the mesh is small on screen. Cost: larger groups report larger errors (the
  // largest collapse of more of them), so at equal tau far meshes take finer levels (2500 dragons
  // at 1080p, tau 1 px: 4.55 M instead of 3.83 M triangles). maxLevels or more: never.
  uint32_t coarserGroupsFromLevel = 4;
  // A group is stuck when simplification keeps more than this fraction of its triangles; its clusters
  // then stay roots of the current level and are regrouped with others at the next level.
  float stuckRatio = 0.85f;
  // Shading-aware error: a collapse that moves the shading normals by an angle a (radians, RMS over
  // the area it merges, hard edges' own spread not counted, at most 0.3 rad) adds
  // normalWeight * l0 * a of distance (in quadrature) to the plane-quadric distance in the reported
  // error, l0 = the input's median edge length; the collapse order sees half of the weight. With l0
  // as the length the term is the same at every level: where the input's triangles are about
  // 1 / (normalWeight * a) pixels or larger on screen a cut keeps the shading within tau, far away
  // (sub-pixel input triangles) the geometric error rules. 12 is tuned on the Stanford dragon's close
  // view (docs/lod.md, "Measurements"): at tau 1 px, 960x540, 41.4 dB single-sample and 44.3 dB
  // 4x4-supersampled against the full mesh (10: 39.8 / 43.5 dB; 0, geometric only: 32.0 / 34.0 dB).
  // 0 = geometric error only. `mirage build --normal-weight W`.
  float normalWeight = 12.0f;
  // Stop once the remaining (root) clusters are at most this many.
  uint32_t rootClusters = 1;
  // Hard cap on levels, a safety net against a pathological mesh (each level halves the triangles).
  uint32_t maxLevels = 48;
  // Worker threads for groups of a level; 0 = TBB's default (all cores).
  uint32_t threads = 0;
};

// Builds the DAG. Errors (never exceptions): empty mesh, out-of-range indices, bad config.
Result<ClusterDag> buildClusterDag(const Mesh& mesh, const BuildConfig& config = {});
// The same, and per input triangle the level-0 cluster holding it (kNone: degenerate, dropped),
// i.e. lod_asset.h's sourceTriangleClusters(mesh, dag), known to the builder at no extra cost.
Result<ClusterDag> buildClusterDag(const Mesh& mesh, const BuildConfig& config, std::vector<uint32_t>* sourceClusters);

} // namespace mirage::lod
