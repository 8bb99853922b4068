// Atlas allocator: placements never overlap and stay inside (random stress, brute-force occupancy),
// deltas rebuild the allocator's state, a still camera moves nothing, freed space is reused, and a
// full atlas degrades to smaller blocks and colour-only patches.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "mirage/stream/atlas.h"
#include "mirage/stream/patches.h"

namespace mirage::stream {
namespace {

AtlasAllocator makeAllocator(AtlasConfig config) {
  auto allocator = AtlasAllocator::create(config);
  EXPECT_TRUE(allocator.ok());
  return std::move(allocator).value();
}

// Every placement inside the atlas, no texel owned twice, usedTexels the sum of the blocks.
void expectDisjoint(const AtlasAllocator& allocator) {
  uint32_t size = allocator.size();
  std::vector<uint8_t> owned(size_t(size) * size, 0);
  uint64_t texels = 0;
  for (const auto& [patch, block] : allocator.placements()) {
    ASSERT_LE(uint64_t(block.x) + block.width(), size) << "patch " << patch;
    ASSERT_LE(uint64_t(block.y) + block.height(), size) << "patch " << patch;
    for (uint32_t y = block.y; y < block.y + block.height(); ++y) {
      for (uint32_t x = block.x; x < block.x + block.width(); ++x) {
        ASSERT_EQ(owned[size_t(y) * size + x]++, 0) << "patch " << patch << " overlaps at " << x << "," << y;
      }
    }
    texels += uint64_t(block.width()) * block.height();
  }
  EXPECT_EQ(allocator.stats().usedTexels, texels);
}

std::vector<AtlasRequest> squares(uint32_t first, uint32_t count, uint32_t log2) {
  std::vector<AtlasRequest> requests;
  for (uint32_t i = 0; i < count; ++i) requests.push_back({first + i, 2, log2});
  return requests;
}

TEST(Atlas, RandomStressStaysDisjointAndDeltasMirrorState) {
  for (uint32_t keep : {0u, 2u}) {
    AtlasAllocator allocator = makeAllocator({.size = 512, .hysteresis = 1, .keepInvisibleFrames = keep});
    std::mt19937 rng(1234 + keep);
    constexpr uint32_t kPatches = 400;
    std::vector<uint32_t> triangles(kPatches), level(kPatches);
    for (uint32_t p = 0; p < kPatches; ++p) {
      triangles[p] = 1 + rng() % 3;
      level[p] = 1 + rng() % 7;
    }
    std::map<uint32_t, AtlasPlacement> mirror; // what a client rebuilds from the deltas
    for (uint32_t frame = 0; frame < 60; ++frame) {
      std::vector<AtlasRequest> visible;
      for (uint32_t p = 0; p < kPatches; ++p) {
        if (rng() % 100 < 60) {
          if (rng() % 4 == 0) level[p] = std::clamp(int(level[p]) + int(rng() % 5) - 2, 1, 7);
          visible.push_back({p, triangles[p], level[p]});
        }
      }
      AtlasUpdate update = allocator.update(visible);
      for (uint32_t patch : update.removed) EXPECT_EQ(mirror.erase(patch), 1u) << "removed unknown patch " << patch;
      for (const auto& placed : update.placed) mirror[placed.patch] = placed.block;
      expectDisjoint(allocator);
      auto placements = allocator.placements();
      ASSERT_EQ(placements.size(), mirror.size());
      for (const auto& [patch, block] : placements) EXPECT_EQ(mirror.at(patch), block);
      // Every visible patch has a block or is colour-only, never both; blocks match the shape.
      for (const AtlasRequest& request : visible) {
        auto block = allocator.placement(request.patch);
        bool colour = std::binary_search(update.colourOnly.begin(), update.colourOnly.end(), request.patch);
        EXPECT_NE(block.has_value(), colour) << "patch " << request.patch;
        if (block) {
          EXPECT_EQ(block->wide, request.triangleCount == 3);
        }
        if (block) {
          EXPECT_LE(block->log2, maxBlockLog2(request.triangleCount));
        }
      }
      EXPECT_EQ(allocator.stats().placedPatches, placements.size());
    }
  }
}

TEST(Atlas, StillCameraMovesNothing) {
  AtlasAllocator allocator = makeAllocator({.size = 1024});
  std::vector<AtlasRequest> visible;
  for (uint32_t p = 0; p < 300; ++p) visible.push_back({p * 3, 1 + p % 3, 1 + p % 6});
  AtlasUpdate first = allocator.update(visible);
  EXPECT_EQ(first.placed.size(), visible.size());
  AtlasUpdate second = allocator.update(visible);
  EXPECT_TRUE(second.placed.empty());
  EXPECT_TRUE(second.removed.empty());
  EXPECT_TRUE(second.colourOnly.empty());
  EXPECT_EQ(allocator.stats().allocations, 0u);

  // Levels wavering by one stay within the hysteresis: still nothing moves.
  for (AtlasRequest& request : visible) request.wantedLog2 += (request.patch % 2) ? 1 : -1;
  AtlasUpdate wavering = allocator.update(visible);
  EXPECT_TRUE(wavering.placed.empty());

  // Two levels off: the patch moves to a block of its wanted level.
  std::vector<AtlasRequest> closer = {{0, 1, 5}};
  closer[0].wantedLog2 = allocator.placement(0)->log2 + 2;
  AtlasUpdate moved = allocator.update(closer);
  ASSERT_EQ(moved.placed.size(), 1u);
  EXPECT_EQ(moved.placed[0].block.log2, closer[0].wantedLog2);
  EXPECT_EQ(allocator.stats().moves, 1u);
  EXPECT_EQ(moved.removed.size(), visible.size() - 1); // everyone else left the view
}

TEST(Atlas, FreedSuperblocksAreReused) {
  AtlasAllocator allocator = makeAllocator({.size = 256});
  allocator.update(squares(0, 64, 4)); // 4 superblocks of 16 x 16 blocks
  EXPECT_EQ(allocator.stats().superblocksInUse, 1u);
  allocator.update(squares(0, 4, 7)); // the same patches 0..3 move up, 4..63 leave
  EXPECT_EQ(allocator.stats().superblocksInUse, 4u);
  EXPECT_EQ(allocator.stats().colourOnly, 0u);
  // A move takes its new block before freeing the old: patch 3 found no free superblock and stays.
  EXPECT_EQ(allocator.placement(3)->log2, 4u);
  AtlasUpdate gone = allocator.update({});
  EXPECT_EQ(gone.removed.size(), 4u);
  EXPECT_EQ(allocator.stats().superblocksInUse, 0u);
  EXPECT_EQ(allocator.stats().usedTexels, 0u);
  // The whole atlas is free again: four new largest blocks fit.
  AtlasUpdate again = allocator.update(squares(100, 4, 7));
  EXPECT_EQ(again.placed.size(), 4u);
  EXPECT_TRUE(again.colourOnly.empty());
  expectDisjoint(allocator);
}

TEST(Atlas, InvisiblePatchesKeptForConfiguredFrames) {
  AtlasAllocator allocator = makeAllocator({.size = 256, .keepInvisibleFrames = 2});
  allocator.update(squares(0, 2, 3));
  auto block = allocator.placement(1);
  auto onlyFirst = squares(0, 1, 3);
  EXPECT_TRUE(allocator.update(onlyFirst).removed.empty());
  EXPECT_TRUE(allocator.update(onlyFirst).removed.empty());
  AtlasUpdate back = allocator.update(squares(0, 2, 3)); // patch 1 returns within the window: same block
  EXPECT_TRUE(back.placed.empty());
  EXPECT_EQ(allocator.placement(1), block);
  allocator.update(onlyFirst);
  allocator.update(onlyFirst);
  AtlasUpdate expired = allocator.update(onlyFirst);
  EXPECT_EQ(expired.removed, std::vector<uint32_t>{1});
}

TEST(Atlas, FullAtlasDegradesThenGoesColourOnly) {
  AtlasAllocator allocator = makeAllocator({.size = 128}); // one superblock
  std::vector<AtlasRequest> visible = squares(0, 10, 5);
  visible.push_back({50, 2, 7}); // the largest wanted block gets the space first
  AtlasUpdate update = allocator.update(visible);
  ASSERT_TRUE(allocator.placement(50).has_value());
  EXPECT_EQ(allocator.placement(50)->log2, 7u);
  EXPECT_EQ(update.colourOnly.size(), 10u);
  EXPECT_EQ(allocator.stats().colourOnly, 10u);

  // Many patches on a small atlas: no crash, each visible patch placed or colour-only.
  AtlasAllocator small = makeAllocator({.size = 256});
  std::vector<AtlasRequest> crowd;
  for (uint32_t p = 0; p < 5000; ++p) crowd.push_back({p, 1 + p % 3, 1 + p % 7});
  AtlasUpdate crowded = small.update(crowd);
  EXPECT_EQ(crowded.placed.size() + crowded.colourOnly.size(), crowd.size());
  EXPECT_GT(crowded.colourOnly.size(), 0u);
  EXPECT_EQ(small.stats().superblocksInUse, small.stats().superblockCount);
  expectDisjoint(small);
  // A full atlas keeps its placements under the same request (colour-only ones retry, still no room).
  AtlasUpdate still = small.update(crowd);
  EXPECT_TRUE(still.placed.empty());
  EXPECT_EQ(still.colourOnly, crowded.colourOnly);

  // When the wanted level has no room, a smaller block of a superblock in use is taken before giving up.
  AtlasAllocator degrade = makeAllocator({.size = 256});
  std::vector<AtlasRequest> requests = squares(0, 3, 7); // 3 of 4 superblocks
  requests.push_back({5, 2, 6});                         // the last one, split into 64 x 64 blocks
  degrade.update(requests);
  requests.push_back({10, 2, 7});
  AtlasUpdate degraded = degrade.update(requests);
  ASSERT_TRUE(degrade.placement(10).has_value());
  EXPECT_EQ(degrade.placement(10)->log2, 6u);
  EXPECT_TRUE(degraded.colourOnly.empty());
  expectDisjoint(degrade);
}

TEST(Atlas, GpuRecordMatchesPlacementAndContract) {
  AtlasAllocator allocator = makeAllocator({.size = 512});
  AtlasUpdate update = allocator.update(std::vector<AtlasRequest>{{7, 3, 5}, {8, 2, 4}});
  ASSERT_EQ(update.placed.size(), 2u);
  Patch wide;
  wide.triangleCount = 3;
  for (uint32_t v = 0; v < 5; ++v) wide.vertices[v] = 10 + v;
  const AtlasPlacement& block = update.placed[0].block; // patch 7, the wide one
  ASSERT_TRUE(block.wide);
  shaderio::GpuAtlasPatch record = gpuAtlasPatch(wide, 1000, 4, 2, block);
  for (uint32_t v = 0; v < 5; ++v) EXPECT_EQ(record.vertices[v], 1010 + v);
  EXPECT_EQ(record.instance, 4u);
  EXPECT_EQ(record.material, 2u);
  EXPECT_EQ(record.blockX, block.x);
  EXPECT_EQ(record.blockY, block.y);
  EXPECT_EQ(record.blockLog2, block.log2);
  // The shaders size the block from triangleCount and blockLog2 alone: it must be the allocated one.
  EXPECT_EQ(shaderio::atlasBlockWidth(record.triangleCount, record.blockLog2), block.width());
}

TEST(Atlas, RejectsBadSizes) {
  EXPECT_FALSE(AtlasAllocator::create({.size = 100}).ok());
  EXPECT_FALSE(AtlasAllocator::create({.size = 64}).ok());
  EXPECT_TRUE(AtlasAllocator::create({.size = 2048}).ok());
}

} // namespace
} // namespace mirage::stream
