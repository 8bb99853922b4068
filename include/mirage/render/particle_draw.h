#pragma once
// Particle billboards in the forward and cluster-LOD renderers (docs/particles.md, "Rendering"):
// camera-facing quads (6 vertices from gl_VertexIndex, one instance per shaderio::RenderParticle
// record, an indirect draw whose instance count is the simulation's live count) textured from a
// flipbook sheet, drawn inside the transparency pass: in linked-list mode they append to the same
// per-pixel lists as the blended scene geometry, so both sort together; weighted mode accumulates
// them; sorted mode sorts them by view depth on the GPU and draws each run between the sorted
// blended triangles it falls between. Depth-tested against the opaque scene, never written.
// Particles a few pixels wide and less are splatted by a compute pass instead (weighted blended
// sums per pixel, resolved after the transparency composite), unless turned off.
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/render/oit.h"
#include "mirage/shaderio/particle_draw.h"
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
  VkDeviceAddress records = 0; // shaderio::RenderParticle[], 16-byte aligned
  VkBuffer countBuffer = VK_NULL_HANDLE;
  VkDeviceSize countOffset = 0;
  uint32_t count = 0;
  uint32_t sheet = 0; // index into the sheets given to create()
};

// How the splat accumulates (docs/particles.md, "Splat"): float atomic adds where the device has
// them (shaderBufferFloat32AtomicAdd), else 64-bit fixed point (shaderBufferInt64Atomics).
enum class SplatAtomics { Auto, Float, Fixed };

// How the splat gathers each pixel's sums (docs/particles.md, "Splat"): binned by screen tiles
// (per tile, shared-memory sums written once), or every covered pixel's sums added by global
// atomics per particle. Auto: binned.
enum class SplatMethod { Auto, Binned, Atomic };

// Particles whose billboard would be narrower than this many pixels are splatted by default: their
// footprint then touches at most 3 x 3 pixels (a splat thread's whole work).
inline constexpr float kDefaultSplatPixels = 2.0f;

struct ParticleDrawSettings {
  // Particles under this billboard edge in pixels are splatted in compute (order-independent
  // approximate, as weighted blending), the others drawn as billboards; 0: every particle a
  // billboard. At most MIRAGE_SPLAT_MAX_PIXELS. The sorted mode never splats.
  float splatBelowPixels = kDefaultSplatPixels;
  SplatAtomics atomics = SplatAtomics::Auto;
  SplatMethod splatMethod = SplatMethod::Auto;
  // Binned: entries (a splat's footprint on one tile of one eye) the tile lists hold; those past it
  // are added by global atomics, so the image does not depend on it. 0: MIRAGE_SPLAT_ENTRIES_PER_RECORD
  // per record slot (MIRAGE_SPLAT_ENTRY_BYTES each). A larger room: with no frame in flight.
  uint32_t splatEntryRoom = 0;
  // Binned: slots of the table in which a count or scatter workgroup counts its entries per tile
  // (a power of two, at most MIRAGE_SPLAT_BIN_SLOTS); a tile finding no free slot takes global
  // atomics per entry, so the image does not depend on it. 0: MIRAGE_SPLAT_BIN_SLOTS.
  uint32_t splatBinSlots = 0;
};

// Device bytes the splat takes per record slot beyond the renderer's per-pixel sums: the billboard
// list's index, the binned splat's default entry room and its workgroups' tile tables.
inline constexpr uint64_t kSplatBytesPerRecord =
    4 + MIRAGE_SPLAT_ENTRIES_PER_RECORD * MIRAGE_SPLAT_ENTRY_BYTES +
    MIRAGE_SPLAT_BIN_SLOTS * 8 / (MIRAGE_PARTICLE_DRAW_GROUP * MIRAGE_SPLAT_BIN_RECORDS);

// Where a frame's splat writes, given by the renderer recording it.
struct ParticleSplatTarget {
  uint32_t slot = 0;                         // the renderer's frame slot (a descriptor set per slot)
  VkDeviceAddress frames[2] = {};            // each eye's ViewFrame
  uint32_t eyes = 1;                         // stereo: 2, side by side
  uint32_t eyeWidth = 0, height = 0;         // the target is eyes * eyeWidth x height pixels
  VkImageView depth = VK_NULL_HANDLE;        // the opaque depth (D32, reverse-Z), DEPTH_READ_ONLY_OPTIMAL
  VkImageView color = VK_NULL_HANDLE;        // the colour target (RGBA16F), GENERAL: the resolve blends into it
  const gpu::Buffer* accumulators = nullptr; // splatBytes(pixels) bytes, zeroed before cmdSplat
  gpu::GpuTimer* timer = nullptr;            // set: the binned passes timed apart (splat-count .. splat-tiles)
};

class ParticleDraw {
public:
  // Uploads the sheets (at least one; each image non-empty).
  static Result<std::unique_ptr<ParticleDraw>> create(gpu::Context& context, std::span<const ParticleSheet> sheets);
  ~ParticleDraw();

  // Errors (a threshold out of range, float atomics the device lacks) change nothing.
  Status setSettings(const ParticleDrawSettings& settings);
  const ParticleDrawSettings& settings() const;

  // The batches the next frames draw (GPU records owned by the caller, alive while frames use them;
  // more records than before only with no frame in flight that draws them).
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
  // targets): every live record, or after cmdSplat in this recording those it left to billboards.
  // Linked lists append through the OitLists at `oitLists`.
  void cmdDraw(VkCommandBuffer cmd, OitMode mode, VkDeviceAddress frame, VkDeviceAddress oitLists);

  // The splat (docs/particles.md, "Splat"): whether frames in `mode` splat (settings, device,
  // batches; never sorted), and the accumulators' size for a target of `pixels` (both eyes).
  bool splats(OitMode mode) const;
  uint64_t splatBytes(uint64_t pixels) const;
  // After cmdPrepare, outside rendering, the opaque depth written: every live particle under the
  // threshold accumulated into the target's accumulators where it lies in front of the opaque
  // depth, the others listed for cmdDraw. barriers: the accumulators' zeroing (a transfer) and the
  // depth's writes made visible here with the renderer's layout transition; on exit the list and
  // its draw visible to indirect draws and vertex shaders, the sums to compute shaders.
  void cmdSplat(VkCommandBuffer cmd, const ParticleSplatTarget& target);
  // After the transparency composite (the colour's compute writes made visible here): the sums
  // blended over the colour target, as weighted blended transparency resolves.
  void cmdSplatResolve(VkCommandBuffer cmd, const ParticleSplatTarget& target);
  // Benchmarks and tests: particles the last splat pass left to billboards (blocking readback).
  uint32_t readBillboardCount();
  // Whether frames splat binned by screen tiles (settings and device; splats() aside).
  bool splatsBinned() const;

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
