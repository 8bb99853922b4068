#pragma once
// Input preparation shared by the builder and the verifier, so both see the same surface:
// exact position welding and removal of triangles that cannot carry area or cover twice.
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace mirage::lod::detail {

struct Welded {
  std::vector<glm::vec3> positions;     // unique positions (bitwise equal after -0 -> +0)
  std::vector<uint32_t> vertexPosition; // per input vertex
};

// Merges vertices whose positions are exactly equal. Attribute seams (same position, different
// UV/normal) become one position: topology and simplification ignore seams.
Welded weldPositions(const std::vector<glm::vec3>& positions);

// Where the kept triangles came from (the builder's source-triangle map is built from it).
struct KeptSources {
  std::vector<uint32_t> source;                           // per kept triangle: its input triangle
  std::vector<std::pair<uint32_t, uint32_t>> laterCopies; // (input triangle, input triangle it copies), dropped
};

// Keeps triangles whose three welded positions are distinct and drops later copies of a triangle
// over the same three positions (either winding). Returns input-vertex triples; `sources`, when
// given, says which input triangle each kept one is and which dropped ones copy which.
std::vector<uint32_t> cleanTriangles(const std::vector<uint32_t>& indices, const std::vector<uint32_t>& vertexPosition,
                                     KeptSources* sources = nullptr);

inline uint64_t edgeKey(uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a); }

inline uint64_t mix64(uint64_t x) {
  // splitmix64 finalizer: cheap and good enough to spread position bits over a hash table.
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ull;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebull;
  x ^= x >> 31;
  return x;
}

} // namespace mirage::lod::detail
