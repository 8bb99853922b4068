#pragma once
// Compact binary encoding of a ClusterDag for the .mrg 'CDAG' chunk (the container adds zstd and
// checksums on top). Positions are quantized to a grid over the mesh bounds; normals are
// octahedral 16-bit; vertex streams go through meshoptimizer's vertex codec; ids are delta +
// varint coded; each cluster's self/parent LOD bounds are derived from its groups on decode.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod {

inline constexpr uint32_t kDagCodecVersion = 1;

struct DagEncodeOptions {
  // Bits per position axis on a grid spanning the mesh bounds (8..24; above 24: raw floats). 16 bits
  // put the grid step at 1/65535 of the largest extent: far below a pixel for any view that shows
  // the whole mesh. The decoder widens every sphere and error by the step (plus float rounding) so
  // culling and LOD stay conservative. The encoder takes more bits (up to 24, then raw floats) when
  // two distinct positions would decode to one, or a decoded position would move by more than that.
  uint32_t positionBits = 16;
};

std::vector<uint8_t> encodeDag(const ClusterDag& dag, const DagEncodeOptions& options = {});
// Validates every count, range and id; `file` names the source in errors.
Result<ClusterDag> decodeDag(std::span<const uint8_t> bytes, const std::string& file);

} // namespace mirage::lod
