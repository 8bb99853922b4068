#pragma once
// Pieces shared by the 'CDAG' codec (dag_codec.cpp) and the page codec (page_codec.cpp): id lists
// as zigzag deltas, meshoptimizer's vertex codec over fixed-size records, the position grid (its
// choice, quantization and the slack the decoder widens bounds by), and spheres. One grid choice
// serves both codecs, so a page's positions and LOD bounds decode bit for bit as the CDAG chunk's.
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/asset/bytes.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod::detail {

// Ids in order, each as the zigzag delta from the previous one: ids of neighbouring clusters and
// vertices are close, so most take one byte. The count goes first.
void writeIds(asset::ByteWriter& w, std::span<const uint32_t> ids);
// At most `limit` ids (and no more than the bytes left); `what` names them in errors.
bool readIds(asset::ByteReader& r, std::vector<uint32_t>& out, uint64_t limit, const char* what);

// meshopt's vertex codec over fixed-size records; the encoded size goes first.
void writeVertexStream(asset::ByteWriter& w, const void* vertices, size_t count, size_t stride);
// `all` is the span `r` reads (the codec reads the stream in place).
bool readVertexStream(asset::ByteReader& r, std::span<const uint8_t> all, void* out, size_t count, size_t stride);

struct PackedPosition {
  uint32_t x, y, z; // grid coordinates (up to 24 bits used), or the raw float bits
};
static_assert(sizeof(PackedPosition) == 12);

struct PackedAttributes {
  uint32_t normal; // octahedral, snorm16 x (low half) and y
  float u, v;
};
static_assert(sizeof(PackedAttributes) == 12);

// Raw float positions (no grid): stored in the bits field.
inline constexpr uint32_t kRawPositionBits = 32;
inline constexpr uint32_t kMaxGridBits = 24; // float holds every integer up to 2^24 exactly

// The position grid of one mesh: `bits` per axis from `origin` in steps of `step`, or raw floats
// (bits = kRawPositionBits, origin 0, step 1).
struct PositionGrid {
  uint32_t bits = kRawPositionBits;
  glm::vec3 origin{0.0f};
  float step = 1.0f;
  bool raw() const { return bits == kRawPositionBits; }
};

// The grid for `positions` with at least `requestedBits` (8..24; above 24: raw floats): more bits
// are taken until distinct positions stay distinct and each decodes within positionSlack. `packed`
// receives the positions on it (raw: their float bits).
PositionGrid choosePositionGrid(const std::vector<glm::vec3>& positions, uint32_t requestedBits,
                                std::vector<PackedPosition>& packed);
// One position on `grid` (the caller checked that it is one of the positions the grid was chosen
// for, or at least inside its box).
PackedPosition packPosition(const PositionGrid& grid, glm::vec3 p);
// A grid coordinate as the decoder places it.
glm::vec3 unpackPosition(const PositionGrid& grid, const PackedPosition& p);
// How far a decoded position may be from the original (0 for raw floats).
float positionSlack(const PositionGrid& grid);
// A grid read from a file is usable: bits in range, finite origin, step and slack.
bool gridValid(const PositionGrid& grid);
// Packed coordinates within the grid (raw: finite floats).
bool packedValid(const PositionGrid& grid, const PackedPosition& p);

void writeGrid(asset::ByteWriter& w, const PositionGrid& grid);
bool readGrid(asset::ByteReader& r, PositionGrid& grid); // reads only; check with gridValid

// Decoded LOD bounds grow by the position slack so culling and LOD stay conservative: group
// spheres by slack * (level + 2) (nested spheres stay nested level over level) and errors by
// slack; cluster culling spheres by slack. Every decoder applies exactly these operations, so one
// group decodes to the same floats from the CDAG chunk, the page table and every page.
LodBounds widenGroupBounds(LodBounds b, uint32_t groupLevel, float slack);
float widenClusterRadius(float radius, float slack);

void writeSphere(asset::ByteWriter& w, const LodBounds& b);
bool readSphere(asset::ByteReader& r, LodBounds& b);

} // namespace mirage::lod::detail
