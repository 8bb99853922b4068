#pragma once
// The shading atlas allocator (docs/stream.md, "Atlas"): hands visible patches blocks of a
// square atlas, frame by frame, keeping a patch's block while it stays visible so that its texels
// stay put (temporal coherence: unchanged blocks cost the video codec almost nothing).
//
// The atlas is split into superblocks of 2^MIRAGE_ATLAS_MAX_BLOCK_LOG2 texels; each superblock in
// use holds blocks of one size and shape (square h x h, or wide 2h x h for 3-triangle patches),
// tracked by a bitmask; a superblock whose last block is freed returns to the pool.
#include <cstdint>
#include <optional>
#include <set>
#include <span>
#include <vector>

#include "mirage/core/dense_id_map.h"
#include "mirage/core/result.h"
#include "mirage/shaderio/atlas.h"
#include "mirage/stream/patches.h"

namespace mirage::stream {

// Where a patch's block lies: its first texel and its height 2^log2 (width twice that when wide).
struct AtlasPlacement {
  uint32_t x = 0;
  uint32_t y = 0;
  uint32_t log2 = 0;
  bool wide = false; // a 3-triangle patch's 2h x h block

  uint32_t width() const { return (wide ? 2u : 1u) << log2; }
  uint32_t height() const { return 1u << log2; }
  bool operator==(const AtlasPlacement&) const = default;
};

// A visible patch this frame: its global id, triangle count (3: wide block) and wanted block log2
// (patchBlockLog2; clamped to [MIRAGE_ATLAS_MIN_BLOCK_LOG2, maxBlockLog2(triangleCount)]).
struct AtlasRequest {
  uint32_t patch = 0;
  uint32_t triangleCount = 1;
  uint32_t wantedLog2 = MIRAGE_ATLAS_MIN_BLOCK_LOG2;
};

struct AtlasConfig {
  uint32_t size = 2048; // atlas side in texels: a power of two >= the superblock side
  // A visible patch keeps its block while |wanted - block log2| <= hysteresis: a patch whose
  // projected size wavers around a level boundary does not move back and forth.
  uint32_t hysteresis = 1;
  // Frames a patch keeps its block after it was last visible (0: freed the first frame it is not).
  uint32_t keepInvisibleFrames = 0;
};

// What changed this frame, as the protocol sends it.
struct AtlasUpdate {
  struct Placed {
    uint32_t patch;
    AtlasPlacement block;
  };
  std::vector<Placed> placed;       // patches with a new block (added, or moved), ascending patch id
  std::vector<uint32_t> removed;    // patches whose block was freed (no longer visible), ascending
  std::vector<uint32_t> colourOnly; // visible patches without a block this frame (atlas full), ascending
};

struct AtlasStats {
  uint64_t usedTexels = 0; // texels of all blocks in use
  uint32_t superblocksInUse = 0;
  uint32_t superblockCount = 0;
  uint32_t placedPatches = 0; // patches holding a block
  uint32_t allocations = 0;   // blocks handed out this frame (new and moved patches)
  uint32_t moves = 0;         // of those, patches that left an old block
  uint32_t frees = 0;         // blocks freed this frame (moves included)
  uint32_t colourOnly = 0;    // visible patches without a block this frame
};

// Frame update, in this order:
// 1. blocks of patches not visible for more than keepInvisibleFrames frames are freed (`removed`);
// 2. visible patches keep their blocks while within the hysteresis;
// 3. the others ask for a block, largest wanted block first (closest, biggest on screen; ties by
//    patch id): a patch with a block moves only if a block of a level between its wanted and its
//    current one (wanted first) is free, else it keeps its block; a patch without a block takes
//    its wanted level, else the next smaller one down to MIRAGE_ATLAS_MIN_BLOCK_LOG2, else it is
//    colour-only this frame (retried the next). Blocks in use are never taken from visible
//    patches to make room: coherence before resolution.
class AtlasAllocator {
public:
  // An error when size is not a power of two in [superblock side, 32768].
  static Result<AtlasAllocator> create(const AtlasConfig& config);

  AtlasUpdate update(std::span<const AtlasRequest> visible);

  std::optional<AtlasPlacement> placement(uint32_t patch) const;
  // Every patch holding a block (any order).
  std::vector<std::pair<uint32_t, AtlasPlacement>> placements() const;
  const AtlasStats& stats() const { return stats_; }
  uint32_t size() const { return config_.size; }

private:
  struct Superblock {
    std::vector<uint64_t> used; // one bit per block slot
    uint32_t usedCount = 0;
    uint32_t sizeClass = 0; // log2 * 2 + wide
  };
  struct Held {
    AtlasPlacement block;
    uint32_t superblock;
    uint32_t slot;
    uint64_t lastVisibleFrame;
  };

  explicit AtlasAllocator(const AtlasConfig& config);
  std::optional<Held> allocate(uint32_t log2, bool wide);
  void release(const Held& held);

  AtlasConfig config_;
  uint32_t superblocksPerRow_ = 0;
  std::vector<Superblock> superblocks_;
  std::set<uint32_t> emptySuperblocks_;     // the pool, lowest index first
  std::vector<std::set<uint32_t>> partial_; // per size class: superblocks with a free slot
  DenseIdMap<Held> held_;                   // patch -> its block
  uint64_t frame_ = 0;
  AtlasStats stats_;
};

// The shading stage's record of a placed patch (shaderio/atlas.h): slots a..e as merged vertex
// indices (the patch's mesh-local indices + meshVertexOffset, where the mesh's vertices start in
// the merged vertex buffer), the instance and material, and the block.
shaderio::GpuAtlasPatch gpuAtlasPatch(const Patch& patch, uint32_t meshVertexOffset, uint32_t instance,
                                      uint32_t material, const AtlasPlacement& block);

} // namespace mirage::stream
