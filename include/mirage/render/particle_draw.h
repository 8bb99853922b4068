#pragma once
// Particle billboards in the forward and cluster-LOD renderers (docs/particles.md, "Rendering"):
// camera-facing quads (6 vertices from gl_VertexIndex, one instance per shaderio::RenderParticle
// record, an indirect draw whose instance count is the simulation's live count) textured from a
// flipbook sheet, drawn inside the transparency pass: in linked-list mode they append to the same
// per-pixel lists as the blended scene geometry, so both sort together; weighted mode accumulates
// them; sorted mode sorts them by view depth on the GPU and draws each run between the sorted
// blended triangles it falls between. Depth-tested against the opaque scene, never written.
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/render/oit.h"
#include "mirage/shaderio/particles.h"

namespace mirage::render {

// A flipbook of tilesX x tilesY frames, row-major from the top left (RenderParticle::frame).
// alphaFromGreyscale: the coverage is the texel's luminance (the colour is the particle's);
// otherwise colour and alpha multiply the particle's. Sampled as UNORM (linear), with mips.
struct ParticleSheet {
  ImageRGBA8 image;
  uint32_t tilesX = 1, tilesY = 1;
  bool alphaFromGreyscale = false;
};

// One draw's records on the GPU: `count` of them, or, with countBuffer, as many as the uint at
// countBuffer + countOffset holds when the frame runs (at most `capacity`, the records' room).
struct ParticleBatch {
  VkDeviceAddress records = 0; // shaderio::RenderParticle[]
  VkBuffer countBuffer = VK_NULL_HANDLE;
  VkDeviceSize countOffset = 0;
  uint32_t count = 0;
  uint32_t sheet = 0; // index into the sheets given to create()
};

class ParticleDraw {
public:
  // Uploads the sheets (at least one; each image non-empty).
  static Result<std::unique_ptr<ParticleDraw>> create(gpu::Context& context, std::span<const ParticleSheet> sheets);
  ~ParticleDraw();

  // The batches the next frames draw (GPU records owned by the caller, alive while frames use them).
  void setBatches(std::vector<ParticleBatch> batches);
  // CPU records: copied into a buffer of this object, one batch per span (sheet by index); call
  // with no frame in flight that draws particles.
  struct CpuBatch {
    std::span<const shaderio::RenderParticle> records;
    uint32_t sheet = 0;
  };
  void setCpuBatches(std::span<const CpuBatch> batches);
  size_t batchCount() const;

  // Used by the renderers' transparency passes (forward_oit.cpp, cluster_particles.cpp).
  // Outside rendering: the batches' instance counts into the indirect arguments, the batch table
  // the compute passes read. barriers: the records written (the frame's first barrier); on exit
  // the arguments visible to indirect draws and compute shaders.
  void cmdPrepare(VkCommandBuffer cmd);
  // Inside rendering, per eye (`frame`: the eye's ViewFrame, the first member of FrameData and
  // ClusterFrame): the billboards, with the pipeline of `mode` (D32 depth, the forward colour
  // targets). Linked lists append through the OitLists at `oitLists`.
  void cmdDraw(VkCommandBuffer cmd, OitMode mode, VkDeviceAddress frame, VkDeviceAddress oitLists);

  // Sorted mode (OitMode::Sorted): after cmdPrepare, outside rendering, every live record of every
  // batch sorted on the GPU back to front by its centre's view z under `view`, then split into
  // triangleCount + 1 gaps by the view z of the blended triangles, ascending (farthest first),
  // float[triangleCount] at `triangleDepths`: gap g's particles lie between triangle g - 1 and
  // triangle g. `gapDraws` (STORAGE | INDIRECT | TRANSFER_DST, at least triangleCount + 1
  // VkDrawIndirectCommand) receives each gap's draw. barriers: on exit the draws and keys visible
  // to indirect draws and vertex shaders.
  void cmdSort(VkCommandBuffer cmd, const glm::mat4& view, VkDeviceAddress triangleDepths, uint32_t triangleCount,
               const gpu::Buffer& gapDraws);
  // Inside the sorted pass: gap `gap`'s particles, back to front (the sorted pipeline bound here;
  // the caller rebinds its own afterwards).
  void cmdDrawGap(VkCommandBuffer cmd, VkDeviceAddress frame, const gpu::Buffer& gapDraws, uint32_t gap);

  struct Impl;

private:
  explicit ParticleDraw(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::render
