#pragma once
// Invariant checks for a ClusterDag and for the cuts LOCALCUT selects from it. Used by the tests
// and meant for `mirage verify`. Every failure is one line naming the first offending element.
#include <cstdint>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod {

// What every reader of a DAG relies on, checked by decodeDag on every decode: index ranges and ids
// (clusters, local indices, vertices, positions, attributes, groups, roots), clusters in level
// order, group links both ways with each cluster in at most one group as child and as parent, and
// group levels growing from children to parents (so walking the groups terminates). Linear time.
Status checkDagStructure(const ClusterDag& dag);

// checkDagStructure, then: index ranges, cluster sizes, parent/child links both ways, monotonic error
// (self.error <= parent.error, group error >= children's), nested spheres (group sphere contains
// children's self spheres), and each group's outer border and area preserved by its parents
// (border edges equal except on the mesh's own open border, area within 50 % for
// patches off the mesh's own border, no edge newly used by more than two triangles).
Status verifyDag(const ClusterDag& dag);

// LOCALCUT with an object-space threshold: cluster c is drawn iff c.self.error <= threshold <
// c.parent.error. Returns cluster ids in ascending order.
std::vector<uint32_t> selectCut(const ClusterDag& dag, float threshold);

// A cut is watertight and overlap-free: after welding positions, an edge used by one cut triangle
// joins two vertices on the original mesh's open border, no edge is used by more than two
// triangles (more only where the original already had that edge non-manifold), and the cut's area is
// at most 150 % of the original's (and at least 50 % for a closed mesh).
Status verifyCut(const ClusterDag& dag, const std::vector<uint32_t>& cut, const Mesh& original);

} // namespace mirage::lod
