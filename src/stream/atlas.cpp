// The shading atlas allocator (docs/stream.md, "Atlas").
#include "mirage/stream/atlas.h"

#include <algorithm>
#include <bit>
#include <string>

namespace mirage::stream {
namespace {

constexpr uint32_t kSuperblockSide = 1u << MIRAGE_ATLAS_MAX_BLOCK_LOG2;
constexpr uint32_t kSizeClasses = (MIRAGE_ATLAS_MAX_BLOCK_LOG2 + 1) * 2;

uint32_t sizeClass(uint32_t log2, bool wide) { return log2 * 2 + (wide ? 1u : 0u); }
uint32_t blockWidth(uint32_t sizeClass) { return ((sizeClass & 1u) ? 2u : 1u) << (sizeClass / 2); }
uint32_t blockHeight(uint32_t sizeClass) { return 1u << (sizeClass / 2); }
uint32_t slotColumns(uint32_t sizeClass) { return kSuperblockSide / blockWidth(sizeClass); }
uint32_t slotCount(uint32_t sizeClass) { return slotColumns(sizeClass) * (kSuperblockSide / blockHeight(sizeClass)); }

} // namespace

Result<AtlasAllocator> AtlasAllocator::create(const AtlasConfig& config) {
  if (!std::has_single_bit(config.size) || config.size < kSuperblockSide || config.size > 32768) {
    return Error{"atlas: size " + std::to_string(config.size) + " is not a power of two in [" +
                 std::to_string(kSuperblockSide) + ", 32768]"};
  }
  return AtlasAllocator(config);
}

AtlasAllocator::AtlasAllocator(const AtlasConfig& config)
    : config_(config), superblocksPerRow_(config.size / kSuperblockSide),
      superblocks_(size_t(superblocksPerRow_) * superblocksPerRow_), partial_(kSizeClasses) {
  for (uint32_t i = 0; i < superblocks_.size(); ++i) emptySuperblocks_.insert(i);
  stats_.superblockCount = uint32_t(superblocks_.size());
}

std::optional<AtlasAllocator::Held> AtlasAllocator::allocate(uint32_t log2, bool wide) {
  uint32_t cls = sizeClass(log2, wide);
  std::set<uint32_t>& partial = partial_[cls];
  if (partial.empty()) {
    if (emptySuperblocks_.empty()) return std::nullopt;
    uint32_t index = *emptySuperblocks_.begin();
    emptySuperblocks_.erase(emptySuperblocks_.begin());
    Superblock& fresh = superblocks_[index];
    uint32_t slots = slotCount(cls);
    fresh.used.assign((slots + 63) / 64, 0);
    if (slots % 64) fresh.used.back() = ~0ull << (slots % 64); // slots past the end count as used
    fresh.usedCount = 0;
    fresh.sizeClass = cls;
    partial.insert(index);
  }
  uint32_t index = *partial.begin();
  Superblock& superblock = superblocks_[index];
  uint32_t slot = 0;
  for (uint32_t word = 0; word < superblock.used.size(); ++word) {
    if (superblock.used[word] != ~0ull) {
      uint32_t bit = uint32_t(std::countr_one(superblock.used[word]));
      superblock.used[word] |= 1ull << bit;
      slot = word * 64 + bit;
      break;
    }
  }
  if (++superblock.usedCount == slotCount(cls)) partial.erase(index);

  uint32_t columns = slotColumns(cls);
  Held held{};
  held.superblock = index;
  held.slot = slot;
  held.block.x = (index % superblocksPerRow_) * kSuperblockSide + (slot % columns) * blockWidth(cls);
  held.block.y = (index / superblocksPerRow_) * kSuperblockSide + (slot / columns) * blockHeight(cls);
  held.block.log2 = log2;
  held.block.wide = wide;
  stats_.usedTexels += uint64_t(held.block.width()) * held.block.height();
  stats_.allocations++;
  return held;
}

void AtlasAllocator::release(const Held& held) {
  Superblock& superblock = superblocks_[held.superblock];
  superblock.used[held.slot / 64] &= ~(1ull << (held.slot % 64));
  superblock.usedCount--;
  stats_.usedTexels -= uint64_t(held.block.width()) * held.block.height();
  stats_.frees++;
  if (superblock.usedCount == 0) {
    partial_[superblock.sizeClass].erase(held.superblock);
    superblock.used.clear();
    emptySuperblocks_.insert(held.superblock);
  } else {
    partial_[superblock.sizeClass].insert(held.superblock);
  }
}

AtlasUpdate AtlasAllocator::update(std::span<const AtlasRequest> visible) {
  ++frame_;
  stats_.allocations = stats_.moves = stats_.frees = stats_.colourOnly = 0;
  AtlasUpdate out;

  // One request per patch (the largest wanted level), levels clamped to what the shape allows.
  std::vector<AtlasRequest> requests(visible.begin(), visible.end());
  for (AtlasRequest& request : requests) {
    request.wantedLog2 =
        std::clamp(request.wantedLog2, uint32_t(MIRAGE_ATLAS_MIN_BLOCK_LOG2), maxBlockLog2(request.triangleCount));
  }
  std::sort(requests.begin(), requests.end(), [](const AtlasRequest& x, const AtlasRequest& y) {
    return x.patch != y.patch ? x.patch < y.patch : x.wantedLog2 > y.wantedLog2;
  });
  requests.erase(std::unique(requests.begin(), requests.end(),
                             [](const AtlasRequest& x, const AtlasRequest& y) { return x.patch == y.patch; }),
                 requests.end());

  for (const AtlasRequest& request : requests)
    if (Held* held = held_.find(request.patch)) held->lastVisibleFrame = frame_;
  auto& entries = held_.entries();
  for (size_t i = entries.size(); i-- > 0;) { // backwards: an erase moves a visited entry here
    if (entries[i].second.lastVisibleFrame + config_.keepInvisibleFrames < frame_) {
      release(entries[i].second);
      out.removed.push_back(entries[i].first);
      held_.eraseAt(i);
    }
  }

  std::vector<AtlasRequest> needy;
  for (const AtlasRequest& request : requests) {
    const Held* held = held_.find(request.patch);
    bool wide = request.triangleCount == 3;
    if (held && held->block.wide == wide) {
      uint32_t level = held->block.log2;
      uint32_t distance = request.wantedLog2 > level ? request.wantedLog2 - level : level - request.wantedLog2;
      if (distance <= config_.hysteresis) continue;
    }
    needy.push_back(request);
  }
  std::stable_sort(needy.begin(), needy.end(),
                   [](const AtlasRequest& x, const AtlasRequest& y) { return x.wantedLog2 > y.wantedLog2; });

  for (const AtlasRequest& request : needy) {
    bool wide = request.triangleCount == 3;
    Held* held = held_.find(request.patch);
    if (held && held->block.wide == wide) {
      // Move only into a block closer to the wanted level than the current one.
      int current = int(held->block.log2), wanted = int(request.wantedLog2);
      int step = wanted > current ? -1 : 1;
      for (int level = wanted; level != current; level += step) {
        if (auto block = allocate(uint32_t(level), wide)) {
          release(*held);
          block->lastVisibleFrame = frame_;
          *held = *block;
          out.placed.push_back({request.patch, block->block});
          stats_.moves++;
          break;
        }
      }
      continue;
    }
    std::optional<Held> block;
    for (int level = int(request.wantedLog2); level >= MIRAGE_ATLAS_MIN_BLOCK_LOG2 && !block; --level) {
      block = allocate(uint32_t(level), wide);
    }
    if (held && block) { // a block of the wrong shape: replaced
      release(*held);
      stats_.moves++;
    }
    if (block) {
      block->lastVisibleFrame = frame_;
      held_[request.patch] = *block;
      out.placed.push_back({request.patch, block->block});
    } else {
      if (held) { // the wrong shape and no room: it loses its block
        release(*held);
        held_.erase(request.patch);
        out.removed.push_back(request.patch);
      }
      out.colourOnly.push_back(request.patch);
    }
  }

  auto byPatch = [](const AtlasUpdate::Placed& x, const AtlasUpdate::Placed& y) { return x.patch < y.patch; };
  std::sort(out.placed.begin(), out.placed.end(), byPatch);
  std::sort(out.removed.begin(), out.removed.end());
  std::sort(out.colourOnly.begin(), out.colourOnly.end());
  stats_.colourOnly = uint32_t(out.colourOnly.size());
  stats_.placedPatches = uint32_t(held_.size());
  stats_.superblocksInUse = uint32_t(superblocks_.size() - emptySuperblocks_.size());
  return out;
}

std::optional<AtlasPlacement> AtlasAllocator::placement(uint32_t patch) const {
  const Held* held = held_.find(patch);
  if (!held) return std::nullopt;
  return held->block;
}

std::vector<std::pair<uint32_t, AtlasPlacement>> AtlasAllocator::placements() const {
  std::vector<std::pair<uint32_t, AtlasPlacement>> out;
  out.reserve(held_.size());
  for (const auto& [patch, held] : held_) out.emplace_back(patch, held.block);
  return out;
}

shaderio::GpuAtlasPatch gpuAtlasPatch(const Patch& patch, uint32_t meshVertexOffset, uint32_t instance,
                                      uint32_t material, const AtlasPlacement& block) {
  shaderio::GpuAtlasPatch out{};
  for (uint32_t v = 0; v < MIRAGE_ATLAS_MAX_PATCH_VERTICES; ++v) out.vertices[v] = meshVertexOffset + patch.vertices[v];
  out.instance = instance;
  out.material = material;
  out.triangleCount = patch.triangleCount;
  out.blockX = block.x;
  out.blockY = block.y;
  out.blockLog2 = block.log2;
  return out;
}

} // namespace mirage::stream
