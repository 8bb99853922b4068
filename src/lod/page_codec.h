#pragma once
// The page encoder's interface to the layout (paging.cpp): one page's bytes from a list of clusters.
#include <cstdint>
#include <span>
#include <vector>

#include "codec_common.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod::detail {

// What every page of one DAG shares: the grid with the DAG's positions on it, and the decoded
// (widened) LOD bounds written into pages and table.
struct PageEncodeContext {
  const ClusterDag* dag = nullptr;
  PositionGrid grid;
  std::vector<PackedPosition> packed; // per welded position
  std::vector<LodBounds> groupBounds; // per group, widened as the decoders give them
  std::vector<float> clusterRadius;   // per cluster culling radius, widened
  // Scratch: page-local id per attribute vertex (kNone outside the page being encoded).
  std::vector<uint32_t> localId;
};

PageEncodeContext makePageEncodeContext(const ClusterDag& dag, uint32_t positionBits);

struct EncodedPage {
  std::vector<uint8_t> bytes;
  uint32_t vertexCount = 0;
  uint32_t triangleCount = 0;
};

// Page `page` holding `clusters` (DAG ids, in the page's order).
EncodedPage encodePage(PageEncodeContext& ctx, uint32_t page, std::span<const uint32_t> clusters);

} // namespace mirage::lod::detail
