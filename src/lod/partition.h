#pragma once
// Cluster splitting (split.cpp) and cluster grouping (METIS), plus sphere helpers.
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/lod/cluster_dag.h"

namespace mirage::lod::detail {

struct ClusterPiece {
  uint32_t vertexOffset, vertexCount, indexOffset, triangleCount;
};

// Clusters over attribute vertices: vertices are attribute-vertex ids, indices local (8-bit).
struct ClusterSet {
  std::vector<ClusterPiece> pieces;
  std::vector<LodBounds> bounds; // per piece: boundingSphere of its vertices (computed by splitClusters)
  std::vector<uint32_t> vertices;
  std::vector<uint8_t> indices;
};

// Per-thread buffers of splitClusters, reused from call to call (no per-group allocations).
struct SplitScratch {
  std::vector<uint32_t> localOf;         // global vertex id -> local id; all kNone between calls
  std::vector<uint32_t> localOfPosition; // the same for welded positions (build.cpp's group gather)
  std::vector<uint32_t> global, corners, offsets, fill, adjacency, vertStamp, vertLocal, live, candidates;
  std::vector<uint16_t> candScore; // rank << 12 | live sum (split.cpp)
  std::vector<uint8_t> emitted;
  struct TriState {
    uint32_t stamp;   // cluster it is a candidate of
    uint32_t candPos; // its slot in candidates / candScore
    uint32_t liveSum; // score parts: live triangles at its corners,
    uint32_t parts;   // corners outside the cluster, corners with one live triangle left, repeated vertex (split.cpp)
  };
  std::vector<TriState> tri;
  std::vector<uint16_t> edgeUses; // 256 x 256 cluster-local position pairs (build.cpp); all 0 between calls
  std::vector<float> centroids;   // 3x the centroid (only compared): x, y, z arrays (split.cpp)
  std::vector<glm::vec3> vertPos; // per local vertex, its position
  std::vector<glm::vec3> points;  // the current cluster's vertex positions (its sphere)
};

// Splits a triangle list (attribute-vertex ids) into clusters of at most maxVertices/maxTriangles
// by greedy growth: each cluster takes the triangle that adds the fewest new vertices, breadth
// first, and the next cluster starts next to the previous one.
// Positions only pick the nearest triangle when a cluster has no fitting neighbour left, and give
// each cluster its bounding sphere (ClusterSet::bounds). A corner's position is
// positions[vertexPosition[vertex]], or positions[cornerPositions[corner]] when cornerPositions
// (one per entry of `triangles`) is given: a group's simplified mesh has compact local positions.
// emitted, when given, receives the input triangle (index into `triangles` / 3) of every output
// triangle in output order (level 0's source-triangle map).
ClusterSet splitClusters(const std::vector<uint32_t>& triangles, const std::vector<glm::vec3>& positions,
                         const std::vector<uint32_t>& vertexPosition, uint32_t maxVertices, uint32_t maxTriangles,
                         SplitScratch& scratch, std::vector<uint32_t>* emitted = nullptr,
                         const uint32_t* cornerPositions = nullptr);

// Partitions a weighted undirected graph (CSR, symmetric) into `parts` parts by recursive METIS
// bisection (as METIS_PartGraphRecursive, which meshoptimizer found better than Kway for
// clustering), driven from here so that every final part reaches `emit(part, nodes)` (nodes
// ascending) as soon as it is known, depth first, parts in ascending order: the builder starts
// simplifying a group while the rest is still being partitioned. Runs on the calling thread
// (METIS's random numbers come from the C library's shared rand() state: concurrent calls would
// make builds depend on thread timing). A part is emitted at most once; tiny graphs leave some empty.
void partitionGraphRecursive(const std::vector<int32_t>& xadj, const std::vector<int32_t>& adjncy,
                             const std::vector<int32_t>& weights, uint32_t parts,
                             const std::function<void(uint32_t, const std::vector<uint32_t>&)>& emit);

// Smallest sphere of the two that contains both (exact for two spheres).
LodBounds mergeSpheres(const LodBounds& a, const LodBounds& b);
// Sphere around points: bounding-box centre, radius to the farthest point.
LodBounds boundingSphere(const glm::vec3* points, size_t count);

} // namespace mirage::lod::detail
