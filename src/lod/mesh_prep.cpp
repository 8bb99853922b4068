#include "mesh_prep.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>
#include <memory>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mirage::lod::detail {

namespace {

uint32_t floatBits(float f) {
  f += 0.0f; // -0 and +0 weld together
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

// Load factor <= 2/3 keeps linear probing short (the 32-bit tags spare most key reads). Any
// size gives the same result; a smaller table is fewer pages to fault in, which was most of
// weld + clean's time (the dragon's power-of-two tables at <= 0.5 took 24 MB).
size_t tableSize(size_t n) { return std::max<size_t>(16, n + n / 2); }

constexpr uint64_t kEmpty = ~0ull;
constexpr size_t kGrain = 1 << 14;
constexpr size_t kBlock = 16; // inserts whose slots are prefetched together

// Lock-free "first occurrence" table: each key's slot ends up holding the smallest item id with that
// key whatever the thread timing, so the parallel result equals the serial first-come one.
// `same(a, b)` compares the keys of two items; `hash(i)` is item i's key hash. A slot holds the
// item id and the hash's upper 32 bits: items whose bits differ never compare keys, which are
// scattered reads (a probe past an occupied slot read the other triangle's corners and their
// welded positions, two cache misses: a third of cleanTriangles' time).
class FirstOccurrence {
public:
  // Plain words accessed through atomic_ref: an array of std::atomic is zeroed by its constructors
  // on this thread (16 MB for the dragon's triangles) before the parallel fill below.
  explicit FirstOccurrence(size_t items) : size_(tableSize(items)), slots_(new uint64_t[size_]) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, size_, kGrain), [&](const tbb::blocked_range<size_t>& r) {
      std::fill(&slots_[r.begin()], &slots_[r.end()], kEmpty);
    });
  }

  // The table is far larger than the caches and every insert lands at a random slot: callers
  // prefetch a block of slots before inserting it (weld + clean were 13 % of the 5 M blob's build).
  void prefetch(uint64_t hash) const { __builtin_prefetch(&slots_[home(hash)]); }
  void prefetchSlot(uint32_t slot) const { __builtin_prefetch(&slots_[slot]); }

  // Returns the slot of item's key: after every insert finished, first(slot) is the smallest item
  // with that key (a sequential pass over the saved slots instead of probing again). `same(other)`
  // says whether item `other` has item's key.
  template <class Same> uint32_t insert(uint32_t item, uint64_t hash, Same&& same) {
    const uint64_t tag = hash & ~0xffffffffull, entry = tag | item;
    for (size_t h = home(hash);; h = h + 1 == size_ ? 0 : h + 1) {
      std::atomic_ref<uint64_t> slot(slots_[h]);
      uint64_t cur = slot.load(std::memory_order_relaxed);
      if (cur == kEmpty) {
        if (slot.compare_exchange_strong(cur, entry, std::memory_order_relaxed)) return uint32_t(h);
        // Lost the race: cur now holds the winner, fall through and compare with it.
      }
      if ((cur & ~0xffffffffull) != tag || !same(uint32_t(cur))) continue;
      // Only items with this key replace the entry, so cur keeps the tag.
      while (item < uint32_t(cur) && !slot.compare_exchange_weak(cur, entry, std::memory_order_relaxed)) {
      }
      return uint32_t(h);
    }
  }

  // After all inserts (the parallel loop's end orders them before this).
  uint32_t first(uint32_t slot) const { return uint32_t(slots_[slot]); }

private:
  // The hash's lower 32 bits scaled to the table (the upper ones are the slot's tag).
  size_t home(uint64_t hash) const { return size_t((hash & 0xffffffffull) * size_ >> 32); }

  size_t size_;
  std::unique_ptr<uint64_t[]> slots_;
};

// Exclusive prefix sum of flags in parallel blocks: out[i] = number of set flags before i.
uint32_t prefixSum(const std::vector<uint8_t>& flags, std::vector<uint32_t>& out) {
  size_t n = flags.size(), blocks = (n + kGrain - 1) / kGrain;
  out.resize(n);
  std::vector<uint32_t> blockSum(blocks + 1, 0);
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    uint32_t s = 0;
    for (size_t i = b * kGrain; i < std::min(n, (b + 1) * kGrain); ++i) s += flags[i];
    blockSum[b + 1] = s;
  });
  for (size_t b = 0; b < blocks; ++b) blockSum[b + 1] += blockSum[b];
  tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
    uint32_t s = blockSum[b];
    for (size_t i = b * kGrain; i < std::min(n, (b + 1) * kGrain); ++i) out[i] = s, s += flags[i];
  });
  return blockSum[blocks];
}

} // namespace

Welded weldPositions(const std::vector<glm::vec3>& positions) {
  size_t n = positions.size();
  Welded w;
  w.vertexPosition.resize(n);
  auto hash = [&](uint32_t i) {
    glm::vec3 p = positions[i];
    return mix64((uint64_t(floatBits(p.x)) << 32 | floatBits(p.y)) ^ mix64(floatBits(p.z)));
  };
  // Parallel: on 21M-vertex inputs the serial table was a large part of level 0.
  FirstOccurrence table(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    uint64_t hashes[kBlock];
    for (size_t b = r.begin(); b < r.end(); b += kBlock) {
      size_t e = std::min(r.end(), b + kBlock);
      for (size_t i = b; i < e; ++i) table.prefetch(hashes[i - b] = hash(uint32_t(i)));
      for (size_t i = b; i < e; ++i) {
        uint32_t px = floatBits(positions[i].x), py = floatBits(positions[i].y), pz = floatBits(positions[i].z);
        auto same = [&](uint32_t o) {
          glm::vec3 q = positions[o];
          return px == floatBits(q.x) && py == floatBits(q.y) && pz == floatBits(q.z);
        };
        w.vertexPosition[i] = table.insert(uint32_t(i), hashes[i - b], same); // slot for now
      }
    }
  });
  std::vector<uint8_t> isFirst(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      if (i + kBlock < r.end()) table.prefetchSlot(w.vertexPosition[i + kBlock]);
      uint32_t f = table.first(w.vertexPosition[i]);
      w.vertexPosition[i] = f;
      isFirst[i] = f == i;
    }
  });
  // Welded ids in order of first occurrence (as the serial weld numbered them).
  std::vector<uint32_t> id;
  w.positions.resize(prefixSum(isFirst, id));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      if (isFirst[i]) w.positions[id[i]] = positions[i] + glm::vec3(0.0f);
      w.vertexPosition[i] = id[w.vertexPosition[i]];
    }
  });
  return w;
}

std::vector<uint32_t> cleanTriangles(const std::vector<uint32_t>& indices, const std::vector<uint32_t>& vertexPosition,
                                     KeptSources* sources) {
  size_t triCount = indices.size() / 3;
  auto sortedKey = [&](uint32_t t) {
    const uint32_t* tri = &indices[size_t(t) * 3];
    std::array<uint32_t, 3> k{vertexPosition[tri[0]], vertexPosition[tri[1]], vertexPosition[tri[2]]};
    if (k[0] > k[1]) std::swap(k[0], k[1]);
    if (k[1] > k[2]) std::swap(k[1], k[2]);
    if (k[0] > k[1]) std::swap(k[0], k[1]);
    return k;
  };
  auto hash = [](const std::array<uint32_t, 3>& k) { return mix64((uint64_t(k[0]) << 32 | k[1]) ^ mix64(k[2])); };
  // Keep the first of each set of triangles over the same three positions, skip zero-area ones.
  FirstOccurrence table(triCount);
  std::vector<uint8_t> keep(triCount);
  std::vector<uint32_t> slot(triCount);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, triCount, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    std::array<uint32_t, 3> keys[kBlock];
    uint64_t hashes[kBlock];
    for (size_t b = r.begin(); b < r.end(); b += kBlock) {
      size_t e = std::min(r.end(), b + kBlock);
      for (size_t t = b; t < e; ++t) {
        std::array<uint32_t, 3>& k = keys[t - b];
        k = sortedKey(uint32_t(t));
        keep[t] = k[0] != k[1] && k[1] != k[2]; // zero area by construction otherwise
        if (keep[t]) table.prefetch(hashes[t - b] = hash(k));
      }
      for (size_t t = b; t < e; ++t) {
        if (!keep[t]) continue;
        const std::array<uint32_t, 3>& k = keys[t - b];
        slot[t] = table.insert(uint32_t(t), hashes[t - b], [&](uint32_t o) { return sortedKey(o) == k; });
      }
    }
  });
  std::vector<uint8_t> laterCopy(sources ? triCount : 0, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, triCount, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t) {
      if (t + kBlock < r.end() && keep[t + kBlock]) table.prefetchSlot(slot[t + kBlock]);
      if (!keep[t]) continue;
      uint32_t first = table.first(slot[t]);
      keep[t] = first == t;
      if (sources && first != t) laterCopy[t] = 1, slot[t] = first; // slot now names the first copy
    }
  });
  if (sources) // rare (duplicates): a serial pass over flags
    for (size_t t = 0; t < triCount; ++t)
      if (laterCopy[t]) sources->laterCopies.push_back({uint32_t(t), slot[t]});
  std::vector<uint32_t> out(size_t(prefixSum(keep, slot)) * 3); // slot becomes the output index
  if (sources) {
    sources->source.resize(out.size() / 3);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, triCount, kGrain), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t t = r.begin(); t < r.end(); ++t)
        if (keep[t]) sources->source[slot[t]] = uint32_t(t);
    });
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, triCount, kGrain), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end(); ++t)
      if (keep[t]) std::copy(&indices[t * 3], &indices[t * 3] + 3, &out[size_t(slot[t]) * 3]);
  });
  return out;
}

} // namespace mirage::lod::detail
