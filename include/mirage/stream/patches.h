#pragma once
// Shading-atlas patches (docs/stream.md, "Patches"): each mesh's triangles grouped at load
// into patches of 1-3 edge-adjacent triangles that share one atlas block, laid out exactly as
// shaderio/atlas.h says (vertex slots a..e, t0 = (a, b, c), t1 = (c, b, d), t2 = (b, e, d), each
// keeping its source triangle's winding). Patches are per mesh, shared by the mesh's instances; a
// PatchTable numbers them globally per instance, as the server and clients address them.
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/scene.h"
#include "mirage/shaderio/atlas.h"

namespace mirage::stream {

// One patch of a mesh: 1-3 triangles. Unused vertex slots repeat slot a, unused triangles t0.
struct Patch {
  uint32_t vertices[MIRAGE_ATLAS_MAX_PATCH_VERTICES]{};   // mesh-local vertex indices of slots a..e
  uint32_t triangleCount = 0;                             // 1..3 (3: a wide block)
  uint32_t triangles[MIRAGE_ATLAS_MAX_PATCH_TRIANGLES]{}; // mesh triangle indices of t0..t2
};

struct MeshPatches {
  std::vector<Patch> patches;
  std::vector<uint32_t> patchOfTriangle; // mesh triangle -> index into patches
};

// Groups a mesh's triangles into patches. Triangles are paired greedily across shared edges
// (consistently wound neighbours only: the edge u->v of one is v->u of the other), best texel
// stretch first (patchStretch); a pair is refused when it stretches texels more than
// kMaxPairStretchGrowth times its worse triangle does alone. Triangles left single then join a
// neighbouring pair as its t2 (a wide block) under the same rule; the rest stay single, rotated
// to their least stretched corner order.
MeshPatches buildMeshPatches(const Mesh& mesh);

// How much worse than its triangles alone a patch may stretch texels before a pairing is refused.
constexpr float kMaxPairStretchGrowth = 4.0f;

// Texel stretch of a patch whose slots a..e hold `positions` (world or object space): the ratio of
// the largest to the smallest singular value over the Jacobians (block corner units -> space) of
// its triangles. 1 for a square pair or a 2 x 1 rectangle of three right isosceles triangles;
// grows with shear, aspect and size mismatch; +infinity for degenerate triangles.
float patchStretch(std::span<const glm::vec3> positions, uint32_t triangleCount);

// Positions of the patch's vertex slots a..e (unused slots repeat a) in the mesh's object space.
void patchPositions(const Mesh& mesh, const Patch& patch, glm::vec3 out[MIRAGE_ATLAS_MAX_PATCH_VERTICES]);

// A patch of the scene: the instance it belongs to and its index in the instance's mesh patches.
struct PatchRef {
  uint32_t instance = 0;
  uint32_t meshPatch = 0;
};

// The scene's patches numbered globally: global patch id = instancePatchOffset[instance] + mesh
// patch index; global triangle ids are instance-major (instanceTriangleOffset[instance] + mesh
// triangle index), as the PVS numbers them (visibility/pvs_storage.h).
struct PatchTable {
  std::vector<MeshPatches> meshes;              // per Scene::meshes
  std::vector<uint32_t> instanceMesh;           // per instance: its mesh
  std::vector<uint32_t> instancePatchOffset;    // per instance, plus the total at the end
  std::vector<uint32_t> instanceTriangleOffset; // per instance, plus the total at the end

  uint32_t patchCount() const { return instancePatchOffset.empty() ? 0u : instancePatchOffset.back(); }
  uint32_t triangleCount() const { return instanceTriangleOffset.empty() ? 0u : instanceTriangleOffset.back(); }
  uint32_t globalPatch(PatchRef ref) const { return instancePatchOffset[ref.instance] + ref.meshPatch; }
  // Global patch id -> (instance, mesh patch); id < patchCount().
  PatchRef patchRef(uint32_t globalPatch) const;
  // Global triangle id -> global patch id; id < triangleCount().
  uint32_t patchOfTriangle(uint32_t globalTriangle) const;
  const Patch& patch(PatchRef ref) const { return meshes[instanceMesh[ref.instance]].patches[ref.meshPatch]; }
};

PatchTable buildPatchTable(const Scene& scene);

// World positions of a global patch's vertex slots a..e (unused slots repeat a).
void patchWorldPositions(const Scene& scene, const PatchTable& table, uint32_t globalPatch,
                         glm::vec3 out[MIRAGE_ATLAS_MAX_PATCH_VERTICES]);

// Largest block log2 for a patch: wide (3-triangle) blocks are 2h wide and must fit a superblock,
// so their height stops one level below MIRAGE_ATLAS_MAX_BLOCK_LOG2.
inline uint32_t maxBlockLog2(uint32_t triangleCount) {
  return triangleCount == 3u ? MIRAGE_ATLAS_MAX_BLOCK_LOG2 - 1u : MIRAGE_ATLAS_MAX_BLOCK_LOG2;
}

// Level selection: the block height (log2) that gives the patch about one texel per pixel of its
// projection. With p(v) the pixel position of slot v under `viewProj` and `viewport`, the texel
// distance between adjacent block corners is h - 1, so
//   L = max(|p(b) - p(a)|, |p(c) - p(a)|, |p(d) - p(c)|, |p(d) - p(b)|, |p(e) - p(b)|,
//           |p(c) - p(b)| / sqrt(2), |p(d) - p(e)| / sqrt(2))   (the edges of its triangles)
//   log2 = clamp(ceil(log2(L * 2^bias + 1)), MIRAGE_ATLAS_MIN_BLOCK_LOG2, maxBlockLog2(triangleCount))
// worldPositions holds slots a..e (patchWorldPositions). bias > 0 asks for more texels per pixel, < 0 fewer. A patch
// with a vertex at or behind the eye plane (clip w <= 0) gets the largest block: it is as close as a patch can be.
uint32_t patchBlockLog2(std::span<const glm::vec3> worldPositions, uint32_t triangleCount, const glm::mat4& viewProj,
                        glm::uvec2 viewport, float bias = 0.0f);

// The two steps of patchBlockLog2: L in pixels (+infinity for a vertex at or behind the eye plane),
// and the level of a patch whose L is `length`.
float patchProjectedLength(std::span<const glm::vec3> worldPositions, uint32_t triangleCount, const glm::mat4& viewProj,
                           glm::uvec2 viewport);
uint32_t blockLog2ForLength(float length, uint32_t triangleCount, float bias);

// Atlas texels of a block of height 2^log2 for a patch of triangleCount triangles (3: twice as wide).
inline uint64_t blockTexels(uint32_t log2, uint32_t triangleCount) {
  return (triangleCount == 3u ? 2ull : 1ull) << (2u * log2);
}

// A visible patch as level selection sees it: its projected length L (pixels) and its shape.
struct PatchExtent {
  float length = 0.0f;
  uint32_t triangleCount = 1;
};

// The bias that keeps the blocks the patches want within budgetTexels: `bias` when they fit, else
// the largest bias - k / 4 (k = 1, 2, ...) whose blocks fit, or the one at which every patch of
// finite length is at the smallest level when nothing fits. Lowering every patch's bias alike
// keeps the texel density even across the view when the atlas is too small for one texel per pixel
// (the allocator would otherwise give the largest patches their blocks and the rest none).
float fitLevelBias(std::span<const PatchExtent> patches, float bias, uint64_t budgetTexels);

} // namespace mirage::stream
