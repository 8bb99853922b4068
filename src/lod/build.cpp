// buildClusterDag: level loop (group -> lock -> simplify -> split), see docs/lod.md.
#include <algorithm>
#include <chrono>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <limits>
#include <optional>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_group.h>
#include <tbb/task_arena.h>

#include "build_profile.h"
#include "mesh_prep.h"
#include "morton.h"
#include "mirage/lod/cluster_dag.h"
#include "partition.h"
#include "simplify.h"

namespace mirage::lod {

namespace {

using namespace detail;

struct GroupWork {
  std::vector<uint32_t> children;
  bool stuck = false;
  float simplifyError = 0.0f;
  LodBounds bounds;
  ClusterSet parents;
};

class Builder {
public:
  Builder(ClusterDag& dag, const BuildConfig& cfg, std::chrono::steady_clock::time_point start)
      : dag_(dag), cfg_(cfg), start_(start) {}

  // `triangles` (the cleaned input) is only needed for level 0 and released after it. With
  // sourceClusters, `kept` says which input triangle each kept one is (cleanTriangles) and
  // sourceClusters receives each input triangle's level-0 cluster, filled during level 0.
  void run(std::vector<uint32_t> triangles, KeptSources kept, std::vector<uint32_t>* sourceClusters) {
    if (triangles.empty()) return;
    touches_.assign(dag_.positions.size(), 0);
    // Every level about halves the triangles, so the whole DAG holds about twice the input: reserve
    // once instead of growing (and copying) the flat arrays level by level. Untouched capacity
    // costs no resident memory.
    size_t inputTriangles = triangles.size() / 3;
    normalLength_ = typicalEdgeLength(triangles);
    dag_.clusterIndices.reserve(inputTriangles * 3 * 21 / 10);
    dag_.clusterVertices.reserve(inputTriangles * 21 / 10);
    dag_.clusters.reserve(inputTriangles / cfg_.clusterTriangles * 23 / 10 + 16);
    std::vector<uint32_t> active;
    {
      WallTimer wall(kWallLevel0);
      std::optional<StageTimer> timer(kLevel0);
      const std::vector<uint32_t>* keptSource = sourceClusters ? &kept.source : nullptr;
      Level0 l0 = splitLevel0(triangles, keptSource, sourceClusters);
      triangles = {};
      timer.emplace(kLevel0Append);
      std::vector<uint32_t> setBase(l0.sets.size());
      for (size_t i = 0; i < l0.sets.size(); ++i) {
        setBase[i] = uint32_t(dag_.clusters.size());
        std::vector<uint32_t> ids = appendClusters(l0.sets[i], 0, kNone, nullptr);
        active.insert(active.end(), ids.begin(), ids.end());
      }
      if (sourceClusters) {
        timer.emplace(kSourceMap);
        // The workers wrote set-local cluster numbers; add each set's first cluster id. Dropped
        // copies take their first copy's cluster; degenerate triangles stay kNone.
        tbb::parallel_for(size_t(0), l0.sets.size(), [&](size_t i) {
          for (uint32_t k : l0.source[i]) (*sourceClusters)[kept.source[k]] += setBase[i];
          l0.source[i] = {};
        });
        for (auto [copy, first] : kept.laterCopies) (*sourceClusters)[copy] = (*sourceClusters)[first];
        kept = {};
      }
    }
    std::vector<LevelStats> stats(1);
    stats[0].seconds = float(secondsSince(start_));
    auto levelStart = std::chrono::steady_clock::now();
    uint32_t level = 0;
    uint32_t groupSize = groupClustersAt(0);
    while (active.size() > cfg_.rootClusters && level + 1 < cfg_.maxLevels) {
      float meanAge = 0.0f;
      std::vector<GroupWork> work = groupAndSimplify(active, groupSize, meanAge);
      WallTimer commitWall(kWallCommit);
      StageTimer commitTimer(kCommit);

      std::vector<uint32_t> next;
      uint32_t stuck = 0, made = 0;
      for (GroupWork& w : work) {
        if (w.stuck) {
          ++stuck;
          next.insert(next.end(), w.children.begin(), w.children.end());
          continue;
        }
        ++made;
        commitGroup(w, level, next);
      }
      if (made == 0) {
        // Nothing simplified: regroup into larger groups (fewer locked borders) before giving up.
        if (groupSize >= active.size()) break;
        groupSize = std::min<uint32_t>(groupSize * 2, uint32_t(active.size()));
        continue;
      }
      stats[level].groups = uint32_t(work.size());
      stats[level].stuckGroups = stuck;
      stats[level].meanEdgeAge = meanAge;
      stats.emplace_back().seconds = float(secondsSince(levelStart));
      levelStart = std::chrono::steady_clock::now();
      active = std::move(next);
      ++level;
      groupSize = groupClustersAt(level);
    }
    for (uint32_t c : active) {
      Cluster& cl = dag_.clusters[c];
      cl.group = kNone;
      cl.parent = cl.self;
      cl.parent.error = std::numeric_limits<float>::infinity();
    }
    dag_.roots = active;
    std::sort(dag_.roots.begin(), dag_.roots.end());
    finishStats(stats);
  }

private:
  // Clusters per group when grouping clusters of `level` (BuildConfig::coarseGroupsFromLevel,
  // coarserGroupsFromLevel).
  uint32_t groupClustersAt(uint32_t level) const {
    uint64_t n = cfg_.groupClusters;
    if (level >= cfg_.coarserGroupsFromLevel)
      n *= 4;
    else if (level >= cfg_.coarseGroupsFromLevel)
      n *= 2;
    return uint32_t(std::min<uint64_t>(n, uint64_t(1) << 31));
  }

  // Typical edge length of the cleaned input: the median over (at most 65 536 evenly spaced)
  // triangles of their RMS edge length. The median, not the mean: a few long edges over flat parts
  // (modelled meshes) would otherwise set the scale of the finely tessellated rest.
  float typicalEdgeLength(const std::vector<uint32_t>& triangles) const {
    size_t n = triangles.size() / 3;
    if (n == 0) return 0.0f;
    size_t step = (n + 65535) / 65536;
    std::vector<float> len2;
    len2.reserve(n / step + 1);
    for (size_t t = 0; t < n; t += step) {
      glm::vec3 p[3];
      for (int k = 0; k < 3; ++k) p[k] = dag_.positions[dag_.vertexPosition[triangles[t * 3 + k]]];
      len2.push_back(glm::dot(p[1] - p[0], p[1] - p[0]) + glm::dot(p[2] - p[1], p[2] - p[1]) +
                     glm::dot(p[0] - p[2], p[0] - p[2]));
    }
    std::nth_element(len2.begin(), len2.begin() + len2.size() / 2, len2.end());
    return std::sqrt(len2[len2.size() / 2] / 3.0f);
  }

  // Level-0 clusters. Large inputs are sorted along a Morton curve and cut into chunks that are
  // split in parallel; a chunk border costs at most one partly filled cluster per chunk. Chunks
  // of 16 clusters, not 256: the splitter's nearest-triangle fallback scans its whole input, so
  // level 0 cost 3200 instructions per triangle on the dragon at 256 and 2000 at 16 (level-0
  // fill stays 1.00, and the dragon even gets 6817 level-0 clusters instead of 6831).
  struct Level0 {
    std::vector<ClusterSet> sets;
    std::vector<std::vector<uint32_t>> source; // per set, its triangles (indices into `triangles` / 3)
  };
  // With keptSource (input triangle of each of `triangles`), also writes each input triangle's
  // cluster number within its set into sourceClusters (run() adds the sets' first cluster ids).
  Level0 splitLevel0(const std::vector<uint32_t>& triangles, const std::vector<uint32_t>* keptSource,
                     std::vector<uint32_t>* sourceClusters) const {
    size_t triCount = triangles.size() / 3;
    const size_t chunk = size_t(cfg_.clusterTriangles) * 16;
    Level0 out;
    // Emitted triangles (already mapped to `triangles`) -> set-local cluster numbers.
    auto recordSource = [&](const ClusterSet& set, const std::vector<uint32_t>& emitted) {
      for (size_t p = 0; p < set.pieces.size(); ++p) {
        const ClusterPiece& piece = set.pieces[p];
        for (uint32_t t = 0; t < piece.triangleCount; ++t)
          (*sourceClusters)[(*keptSource)[emitted[piece.indexOffset / 3 + t]]] = uint32_t(p);
      }
    };
    if (triCount <= chunk * 2) {
      out.source.resize(1);
      out.sets.push_back(splitClusters(triangles, dag_.positions, dag_.vertexPosition, cfg_.clusterVertices,
                                       cfg_.clusterTriangles, splitScratch_.local(),
                                       keptSource ? &out.source[0] : nullptr));
      if (keptSource) recordSource(out.sets[0], out.source[0]);
      return out;
    }
    Bounds box;
    for (const glm::vec3& p : dag_.positions) box.add(p);
    glm::vec3 scale = 1023.0f / glm::max(box.extent(), glm::vec3(1e-30f));
    std::vector<uint32_t> code(triCount);
    tbb::parallel_for(size_t(0), triCount, [&](size_t t) {
      glm::vec3 c(0.0f);
      for (int k = 0; k < 3; ++k) c += dag_.positions[dag_.vertexPosition[triangles[t * 3 + k]]];
      glm::uvec3 q = glm::uvec3(glm::clamp((c / 3.0f - box.min) * scale, glm::vec3(0.0f), glm::vec3(1023.0f)));
      code[t] = spreadBits(q.x) | spreadBits(q.y) << 1 | spreadBits(q.z) << 2;
    });
    std::vector<uint32_t> order = sortIdsByKey(std::move(code)); // triangles along the Morton curve
    size_t chunks = (triCount + chunk - 1) / chunk;
    out.sets.resize(chunks);
    out.source.resize(chunks);
    tbb::parallel_for(size_t(0), chunks, [&](size_t i) {
      std::vector<uint32_t> part;
      size_t begin = i * chunk, end = std::min(triCount, (i + 1) * chunk);
      part.reserve((end - begin) * 3);
      for (size_t j = begin; j < end; ++j) {
        // Morton order scatters the reads over the whole index buffer: fetch ahead.
        if (j + 16 < end) __builtin_prefetch(&triangles[size_t(order[j + 16]) * 3]);
        part.insert(part.end(), &triangles[size_t(order[j]) * 3], &triangles[size_t(order[j]) * 3] + 3);
      }
      std::vector<uint32_t>* source = keptSource ? &out.source[i] : nullptr;
      out.sets[i] = splitClusters(part, dag_.positions, dag_.vertexPosition, cfg_.clusterVertices,
                                  cfg_.clusterTriangles, splitScratch_.local(), source);
      if (source) {
        for (uint32_t& t : *source) t = order[begin + t]; // chunk-local -> `triangles`
        recordSource(out.sets[i], *source);
      }
    });
    return out;
  }

  // Appends clusters of one set; `self` null means level 0 (own sphere, zero error).
  std::vector<uint32_t> appendClusters(const ClusterSet& set, uint32_t level, uint32_t generatingGroup,
                                       const LodBounds* self) {
    std::vector<uint32_t> ids;
    for (const ClusterPiece& p : set.pieces) {
      Cluster c;
      c.vertexOffset = uint32_t(dag_.clusterVertices.size());
      c.triangleOffset = uint32_t(dag_.clusterIndices.size() / 3);
      c.vertexCount = uint16_t(p.vertexCount);
      c.triangleCount = uint16_t(p.triangleCount);
      c.level = level;
      c.generatingGroup = generatingGroup;
      dag_.clusterVertices.insert(dag_.clusterVertices.end(), set.vertices.begin() + p.vertexOffset,
                                  set.vertices.begin() + p.vertexOffset + p.vertexCount);
      dag_.clusterIndices.insert(dag_.clusterIndices.end(), set.indices.begin() + p.indexOffset,
                                 set.indices.begin() + p.indexOffset + p.triangleCount * 3);
      c.bounds = set.bounds[size_t(&p - set.pieces.data())];
      c.self = self ? *self : c.bounds;
      if (!self) c.self.error = 0.0f;
      ids.push_back(uint32_t(dag_.clusters.size()));
      dag_.clusters.push_back(c);
    }
    return ids;
  }

  template <class F> void forTriangles(uint32_t cluster, F&& f) const {
    const Cluster& c = dag_.clusters[cluster];
    const uint32_t* verts = &dag_.clusterVertices[c.vertexOffset];
    const uint8_t* idx = &dag_.clusterIndices[size_t(c.triangleOffset) * 3];
    for (uint32_t t = 0; t < c.triangleCount; ++t) f(verts[idx[t * 3]], verts[idx[t * 3 + 1]], verts[idx[t * 3 + 2]]);
  }

  // Edges (welded position keys) used by exactly one triangle of the cluster, in no particular
  // order. Counted in a per-thread table over cluster-local position pairs (a cluster has at most
  // 255 vertices) instead of sorting every edge key: the sort was a fifth of the partition stage.
  void clusterBorder(uint32_t cluster, std::vector<uint64_t>& out) const {
    const Cluster& c = dag_.clusters[cluster];
    SplitScratch& s = splitScratch_.local();
    std::vector<uint32_t>& localOf = s.localOfPosition;
    if (localOf.size() < dag_.positions.size()) localOf.resize(dag_.positions.size(), kNone);
    if (s.edgeUses.size() < 256 * 256) s.edgeUses.assign(256 * 256, 0);
    std::vector<uint32_t>& local = s.vertLocal; // cluster vertex -> local position id
    std::vector<uint32_t>& positions = s.global;
    local.resize(c.vertexCount);
    positions.clear();
    const uint32_t* verts = &dag_.clusterVertices[c.vertexOffset];
    for (uint32_t v = 0; v < c.vertexCount; ++v) {
      if (v + 16 < c.vertexCount) __builtin_prefetch(&dag_.vertexPosition[verts[v + 16]]); // scattered ids
      if (v + 8 < c.vertexCount) __builtin_prefetch(&localOf[dag_.vertexPosition[verts[v + 8]]]);
      uint32_t p = dag_.vertexPosition[verts[v]];
      uint32_t& l = localOf[p];
      if (l == kNone) l = uint32_t(positions.size()), positions.push_back(p);
      local[v] = l;
    }
    std::vector<uint32_t>& touched = s.candidates;
    touched.clear();
    const uint8_t* idx = &dag_.clusterIndices[size_t(c.triangleOffset) * 3];
    for (uint32_t t = 0; t < c.triangleCount; ++t)
      for (int k = 0; k < 3; ++k) {
        uint32_t a = local[idx[t * 3 + k]], b = local[idx[t * 3 + (k + 1) % 3]];
        uint32_t pair = std::min(a, b) << 8 | std::max(a, b);
        if (s.edgeUses[pair]++ == 0) touched.push_back(pair);
      }
    for (uint32_t pair : touched) {
      if (s.edgeUses[pair] == 1) out.push_back(edgeKey(positions[pair >> 8], positions[pair & 255]));
      s.edgeUses[pair] = 0;
    }
    for (uint32_t p : positions) localOf[p] = kNone;
  }

  // Every cluster's border edges as (edge key, cluster) in ascending order: a counting sort on
  // the key's lower position id, then a sort of each bucket's few entries. Parallel throughout
  // (atomic counters; the bucket sort makes the order independent of the scatter's timing) and
  // the same order as sorting all entries, which was the largest step of grouping after METIS.
  std::vector<std::pair<uint64_t, uint32_t>> sortedBorderEntries(const std::vector<std::vector<uint64_t>>& borders) {
    // Buckets of 2^shift consecutive lower position ids, about as many as entries: the upper
    // levels have few entries, and buckets per position made every level pass over all positions
    // three times (part of the serial grouping time). Any bucket width gives the same order.
    size_t positions = dag_.positions.size(), total = 0;
    for (const std::vector<uint64_t>& b : borders) total += b.size();
    uint32_t shift = 0;
    while (shift < 31 && (positions >> shift) > total) ++shift;
    size_t buckets = (positions >> shift) + 1;
    std::vector<uint32_t>& end = bucketStart_; // per bucket: its end, once scattered
    end.assign(buckets + 1, 0);
    tbb::parallel_for(size_t(0), borders.size(), [&](size_t i) {
      for (uint64_t k : borders[i])
        std::atomic_ref<uint32_t>(end[(k >> 32 >> shift) + 1]).fetch_add(1, std::memory_order_relaxed);
    });
    for (size_t p = 0; p < buckets; ++p) end[p + 1] += end[p]; // end[p] = bucket p's start for now
    std::vector<std::pair<uint64_t, uint32_t>> entries(end[buckets]);
    tbb::parallel_for(size_t(0), borders.size(), [&](size_t i) {
      for (uint64_t k : borders[i])
        entries[std::atomic_ref<uint32_t>(end[k >> 32 >> shift]).fetch_add(1, std::memory_order_relaxed)] = {
            k, uint32_t(i)};
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, buckets, 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t p = r.begin(); p < r.end(); ++p) {
        auto first = entries.begin() + (p ? end[p - 1] : 0), last = entries.begin() + end[p];
        if (last - first > 1) std::sort(first, last);
      }
    });
    return entries;
  }

  // Groups active clusters with METIS over the cluster adjacency graph and simplifies every group.
  // An edge between two clusters weighs their shared border length times (1 + its age, the levels
  // it has already stayed locked), so long and old borders end up inside groups and get simplified
  // away. The partition's recursive bisection runs on this thread and hands out each group as soon
  // as it is final; other threads simplify it meanwhile (METIS was a serial 7 % of the dragon's
  // build, and the two-thread build sat idle on one core for it). Groups come back in part order
  // (empty ones dropped), whatever the timing.
  std::vector<GroupWork> groupAndSimplify(const std::vector<uint32_t>& active, uint32_t groupSize, float& meanAge) {
    std::optional<WallTimer> wall(kWallGrouping);
    size_t n = active.size();
    uint32_t parts = uint32_t((n + groupSize - 1) / groupSize);
    countTouches(active, true);
    std::vector<std::vector<uint64_t>> borders(n);
    {
      StageTimer timer(kBorders);
      tbb::parallel_for(size_t(0), n, [&](size_t i) { clusterBorder(active[i], borders[i]); });
    }
    std::optional<StageTimer> timer(kPartition);
    std::vector<std::pair<uint64_t, uint32_t>> entries = sortedBorderEntries(borders);
    borders = {}; // level 1 of a large mesh holds millions of these: keep the peak down

    struct Link {
      uint32_t a, b;
      float weight;
      uint64_t key;
    };
    // Shared edges -> links, in blocks of entries processed in parallel (the edge lengths are
    // scattered reads; on the 5 M blob this loop was most of the serial grouping time). A block
    // owns the runs of equal keys that start in it; blocks are joined in order and the lengths
    // summed in key order, so links and weights are those of the serial loop.
    constexpr size_t kEntryBlock = 1 << 14;
    size_t blocks = (entries.size() + kEntryBlock - 1) / kEntryBlock;
    std::vector<std::vector<Link>> blockLinks(blocks);
    std::vector<std::vector<float>> blockLengths(blocks);
    tbb::parallel_for(size_t(0), blocks, [&](size_t blk) {
      size_t j = blk * kEntryBlock, stop = std::min(entries.size(), j + kEntryBlock);
      while (j > 0 && j < stop && entries[j].first == entries[j - 1].first) ++j; // run began earlier
      auto agePos = std::lower_bound(ages_.begin(), ages_.end(),
                                     std::pair<uint64_t, uint32_t>{j < stop ? entries[j].first : 0, 0});
      while (j < stop) {
        size_t e = j;
        while (e < entries.size() && entries[e].first == entries[j].first) ++e;
        if (e - j >= 2) {
          uint64_t key = entries[j].first;
          while (agePos != ages_.end() && agePos->first < key) ++agePos;
          uint32_t age = agePos != ages_.end() && agePos->first == key ? agePos->second : 0;
          float len = glm::distance(dag_.positions[uint32_t(key >> 32)], dag_.positions[uint32_t(key)]);
          blockLengths[blk].push_back(len);
          for (size_t x = j; x < e; ++x)
            for (size_t y = x + 1; y < e; ++y)
              blockLinks[blk].push_back({entries[x].second, entries[y].second, len * float(1 + age), key});
        }
        j = e;
      }
    });
    // Joined in block order: sized once and copied in parallel (the serial, growing join was a
    // sixth of the grouping stage).
    std::vector<size_t> linkStart(blocks + 1, 0);
    for (size_t blk = 0; blk < blocks; ++blk) linkStart[blk + 1] = linkStart[blk] + blockLinks[blk].size();
    std::vector<Link> links(linkStart[blocks]);
    tbb::parallel_for(size_t(0), blocks, [&](size_t blk) {
      std::copy(blockLinks[blk].begin(), blockLinks[blk].end(), links.begin() + linkStart[blk]);
      blockLinks[blk] = {};
    });
    double lengthSum = 0.0;
    for (size_t blk = 0; blk < blocks; ++blk)
      for (float len : blockLengths[blk]) lengthSum += len;
    entries = {};
    std::vector<uint32_t> part(n, 0);
    std::vector<GroupWork> work(std::max(parts, 1u));
    // Declared after `work`, so that on an exception it waits for its tasks before `work` goes.
    tbb::task_group tasks;
    auto emit = [&](uint32_t p, const std::vector<uint32_t>& nodes) {
      GroupWork& w = work[p];
      for (uint32_t i : nodes) part[i] = p, w.children.push_back(active[i]);
      if (!w.children.empty()) tasks.run([this, &w] { simplifyGroup(w); });
    };
    std::vector<int32_t> xadj, adjncy, weights;
    if (parts > 1) {
      float unit = links.empty() ? 1.0f : float(lengthSum / double(links.size())) * 0.25f;
      // Links by their lower cluster (a counting sort; entries come in cluster order, so a < b),
      // each cluster's few links sorted by (other cluster, weight) in parallel, weights summed in
      // that order: the sums a global sort of all (pair, weight) gave, without its serial cost.
      std::vector<uint32_t> start(n + 1, 0);
      for (const Link& l : links) ++start[l.a + 1];
      for (size_t i = 0; i < n; ++i) start[i + 1] += start[i];
      std::vector<std::pair<uint32_t, float>> byLower(links.size());
      {
        std::vector<uint32_t> fill(start.begin(), start.end() - 1);
        for (const Link& l : links) byLower[fill[l.a]++] = {l.b, l.weight};
      }
      std::vector<uint32_t> degree(n + 1, 0);                         // then CSR offsets
      std::vector<std::pair<uint32_t, int32_t>> merged(links.size()); // per lower cluster, prefix used
      std::vector<uint32_t> mergedCount(n, 0);
      tbb::parallel_for(size_t(0), n, [&](size_t a) {
        auto first = byLower.begin() + start[a], last = byLower.begin() + start[a + 1];
        std::sort(first, last);
        uint32_t count = 0;
        for (auto j = first; j != last;) {
          float w = 0.0f;
          auto e = j;
          for (; e != last && e->first == j->first; ++e) w += e->second;
          merged[start[a] + count++] = {j->first, std::max<int32_t>(1, int32_t(std::lround(std::min(w / unit, 1e6f))))};
          j = e;
        }
        mergedCount[a] = count;
      });
      // CSR with every node's neighbours ascending, as the global pair order gave: first the
      // lower neighbours of every node,
      for (size_t a = 0; a < n; ++a) {
        degree[a + 1] += mergedCount[a];
        for (uint32_t j = 0; j < mergedCount[a]; ++j) ++degree[merged[start[a] + j].first + 1];
      }
      for (size_t i = 0; i < n; ++i) degree[i + 1] += degree[i];
      xadj.assign(degree.begin(), degree.end());
      adjncy.resize(degree[n]);
      weights.resize(degree[n]);
      std::vector<uint32_t> fill(degree.begin(), degree.end() - 1);
      for (size_t a = 0; a < n; ++a)
        for (uint32_t j = 0; j < mergedCount[a]; ++j) {
          auto [b, w] = merged[start[a] + j];
          adjncy[fill[b]] = int32_t(a), weights[fill[b]++] = w;
        }
      // Then each node's upper neighbours, after its lower ones (fill[a] points past those).
      for (size_t a = 0; a < n; ++a)
        for (uint32_t j = 0; j < mergedCount[a]; ++j) {
          auto [b, w] = merged[start[a] + j];
          adjncy[fill[a]] = int32_t(b), weights[fill[a]++] = w;
        }
    }
    timer.reset();
    wall.emplace(kWallSimplify);
    if (parts > 1) {
      StageTimer metis(kMetis);
      partitionGraphRecursive(xadj, adjncy, weights, parts, emit);
    } else {
      std::vector<uint32_t> all(n);
      for (size_t i = 0; i < n; ++i) all[i] = uint32_t(i);
      emit(0, all);
    }
    tasks.wait();
    wall.emplace(kWallCommit);
    timer.emplace(kPartition);
    // Edge ages for the next level: borders between different groups stay locked one more level.
    std::vector<std::pair<uint64_t, uint32_t>> ages;
    double ageSum = 0.0;
    size_t agePos = 0;
    for (const Link& l : links) {
      if (part[l.a] == part[l.b]) continue;
      while (agePos < ages_.size() && ages_[agePos].first < l.key) ++agePos;
      uint32_t age = (agePos < ages_.size() && ages_[agePos].first == l.key ? ages_[agePos].second : 0) + 1;
      if (ages.empty() || ages.back().first != l.key) ages.push_back({l.key, age}), ageSum += age;
    }
    meanAge = ages.empty() ? 0.0f : float(ageSum / double(ages.size()));
    ages_ = std::move(ages);
    timer.reset();
    countTouches(active, false);
    work.erase(std::remove_if(work.begin(), work.end(), [](const GroupWork& w) { return w.children.empty(); }),
               work.end());
    return work;
  }

  // Counts (or clears) how many vertex entries of active clusters each position has. A group's
  // position is locked iff the group's own clusters hold fewer of its entries, i.e. a cluster of
  // another group touches it: decided per group, so a group can start before the others are known.
  void countTouches(const std::vector<uint32_t>& active, bool count) {
    StageTimer timer(kOwners);
    if (!count) {
      // Clearing: one sequential fill when the entries are many (the scattered stores through
      // vertexPosition cost more than writing every position's slot: 2 ms a level on the dragon).
      size_t entries = 0;
      for (uint32_t c : active) entries += dag_.clusters[c].vertexCount;
      if (entries * 8 >= touches_.size()) {
        std::fill(touches_.begin(), touches_.end(), 0u);
        return;
      }
    }
    tbb::parallel_for(size_t(0), active.size(), [&](size_t i) {
      const Cluster& cl = dag_.clusters[active[i]];
      for (uint32_t v = 0; v < cl.vertexCount; ++v) {
        std::atomic_ref<uint32_t> t(touches_[dag_.vertexPosition[dag_.clusterVertices[cl.vertexOffset + v]]]);
        if (count)
          t.fetch_add(1, std::memory_order_relaxed);
        else
          t.store(0, std::memory_order_relaxed);
      }
    });
  }

  void simplifyGroup(GroupWork& w) const {
    std::optional<StageTimer> timer(kGather);
    GroupScratch& gs = groupScratch_.local();
    SimplifyMesh& sm = gs.mesh;
    std::vector<uint32_t>& attrs = sm.attributes;
    size_t corners = 0;
    for (uint32_t c : w.children) corners += size_t(dag_.clusters[c].triangleCount) * 3;
    attrs.resize(corners);
    sm.corners.resize(corners);
    // Compact local positions through a flat per-thread map (reset afterwards) instead of sorting:
    // sort + binary search was 10 % of the build. Numbered in corner order; each cluster vertex's
    // position is looked up once (its corners name it by 8-bit index), not once per corner: those
    // lookups are scattered over the whole mesh.
    SplitScratch& scratch = splitScratch_.local();
    std::vector<uint32_t>& localOf = scratch.localOfPosition;
    if (localOf.size() < dag_.positions.size()) localOf.resize(dag_.positions.size(), kNone);
    std::vector<uint32_t>& unique = scratch.global;
    unique.clear();
    // The group's own vertex entries per position (see countTouches): fewer than all of them means
    // another group touches the position, which is then locked.
    std::vector<uint32_t>& own = gs.ownTouches;
    own.clear();
    gs.unnamed.clear();
    uint32_t vertexPos[256], vertexLocal[256]; // per cluster vertex: welded position, local id
    uint32_t* outAttr = attrs.data();
    uint32_t* outCorner = sm.corners.data();
    for (uint32_t c : w.children) {
      const Cluster& cl = dag_.clusters[c];
      const uint32_t* verts = &dag_.clusterVertices[cl.vertexOffset];
      for (uint32_t v = 0; v < cl.vertexCount; ++v) {
        if (v + 8 < cl.vertexCount) __builtin_prefetch(&dag_.vertexPosition[verts[v + 8]]);
        vertexPos[v] = dag_.vertexPosition[verts[v]];
        __builtin_prefetch(&localOf[vertexPos[v]]);
        vertexLocal[v] = kNone;
      }
      const uint8_t* idx = &dag_.clusterIndices[size_t(cl.triangleOffset) * 3];
      for (uint32_t i = 0; i < uint32_t(cl.triangleCount) * 3; ++i) {
        uint32_t k = idx[i];
        if (vertexLocal[k] == kNone) {
          uint32_t& l = localOf[vertexPos[k]];
          if (l == kNone) l = uint32_t(unique.size()), unique.push_back(vertexPos[k]), own.push_back(0);
          vertexLocal[k] = l;
        }
        outAttr[i] = verts[k], outCorner[i] = vertexLocal[k];
      }
      outAttr += size_t(cl.triangleCount) * 3, outCorner += size_t(cl.triangleCount) * 3;
      // A vertex no triangle names (the splitter makes none) counts if another cluster's corner
      // has its position: decided when all are numbered.
      for (uint32_t v = 0; v < cl.vertexCount; ++v)
        if (vertexLocal[v] != kNone)
          ++own[vertexLocal[v]];
        else
          gs.unnamed.push_back(vertexPos[v]);
      // Nested spheres: the group's sphere encloses every child's LOD sphere.
      w.bounds = c == w.children[0] ? cl.self : mergeSpheres(w.bounds, cl.self);
    }
    for (uint32_t p : gs.unnamed)
      if (localOf[p] != kNone) ++own[localOf[p]];
    sm.positions.resize(unique.size());
    sm.locked.resize(unique.size());
    for (size_t i = 0; i < unique.size(); ++i) {
      sm.positions[i] = dag_.positions[unique[i]];
      sm.locked[i] = own[i] < touches_[unique[i]];
      localOf[unique[i]] = kNone;
    }
    sm.normals = dag_.normals.empty() ? nullptr : dag_.normals.data();
    sm.normalWeight = cfg_.normalWeight;
    sm.normalLength = normalLength_;
    size_t before = sm.corners.size() / 3;
    timer.emplace(kSimplify);
    w.simplifyError = simplifyLocked(sm, before / 2, gs.simplify);
    size_t after = sm.corners.size() / 3;
    auto stuck = [&] { return after == 0 || double(after) > double(cfg_.stuckRatio) * double(before); };
    if (stuck()) {
      // No legal collapse left short of the target (tunnels, complex vertices): cluster vertices,
      // which may change topology, so that the DAG still ends in one root.
      float clustered = simplifyClustered(sm, before / 2);
      after = sm.corners.size() / 3;
      if (clustered < 0.0f || stuck()) {
        w.stuck = true;
        return;
      }
      w.simplifyError = std::max(w.simplifyError, clustered);
    }
    timer.emplace(kSplit);
    w.parents = splitClusters(sm.attributes, sm.positions, dag_.vertexPosition, cfg_.clusterVertices,
                              cfg_.clusterTriangles, splitScratch_.local(), nullptr, sm.corners.data());
    // Monotonic error: a parent is never more accurate than the children it replaces.
    float childError = 0.0f;
    for (uint32_t c : w.children) childError = std::max(childError, dag_.clusters[c].self.error);
    w.bounds.error = std::max(w.simplifyError, childError);
  }

  void commitGroup(const GroupWork& w, uint32_t level, std::vector<uint32_t>& next) {
    uint32_t gid = uint32_t(dag_.groups.size());
    Group g;
    g.level = level;
    g.childOffset = uint32_t(dag_.groupChildren.size());
    g.childCount = uint32_t(w.children.size());
    g.bounds = w.bounds;
    g.simplifyError = w.simplifyError;
    for (uint32_t c : w.children) {
      dag_.clusters[c].group = gid;
      dag_.clusters[c].parent = w.bounds;
      dag_.groupChildren.push_back(c);
    }
    std::vector<uint32_t> ids = appendClusters(w.parents, level + 1, gid, &w.bounds);
    g.parentOffset = uint32_t(dag_.groupParents.size());
    g.parentCount = uint32_t(ids.size());
    dag_.groupParents.insert(dag_.groupParents.end(), ids.begin(), ids.end());
    next.insert(next.end(), ids.begin(), ids.end());
    dag_.groups.push_back(g);
  }

  void finishStats(std::vector<LevelStats>& stats) {
    for (const Cluster& c : dag_.clusters) {
      if (c.level >= stats.size()) stats.resize(c.level + 1);
      LevelStats& s = stats[c.level];
      ++s.clusters;
      s.triangles += c.triangleCount;
    }
    for (LevelStats& s : stats)
      s.meanFill = s.clusters ? float(double(s.triangles) / (double(s.clusters) * cfg_.clusterTriangles)) : 0.0f;
    while (!stats.empty() && stats.back().clusters == 0) stats.pop_back();
    dag_.levels = std::move(stats);
  }

  static double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  }

  ClusterDag& dag_;
  const BuildConfig& cfg_;
  std::chrono::steady_clock::time_point start_;
  float normalLength_ = 0.0f;     // the input's typical edge length: the normal term's length scale
  std::vector<uint32_t> touches_; // per position: vertex entries of the level's active clusters
  mutable tbb::enumerable_thread_specific<SplitScratch> splitScratch_;
  struct GroupScratch {
    SimplifyScratch simplify;
    SimplifyMesh mesh;                // the group's triangles: reused, so groups allocate almost nothing
    std::vector<uint32_t> ownTouches; // per local position: vertex entries of the group's clusters
    std::vector<uint32_t> unnamed;    // positions of cluster vertices that no corner names
  };
  mutable tbb::enumerable_thread_specific<GroupScratch> groupScratch_;
  std::vector<std::pair<uint64_t, uint32_t>> ages_; // sorted by edge key: levels locked so far
  std::vector<uint32_t> bucketStart_;               // sortedBorderEntries' counting sort, per position
};

std::string checkConfig(const Mesh& mesh, const BuildConfig& cfg) {
  if (cfg.clusterTriangles < 4 || cfg.clusterTriangles > kMaxClusterTriangles || cfg.clusterTriangles % 4 != 0)
    return "clusterTriangles must be a multiple of 4 in [4, " + std::to_string(kMaxClusterTriangles) + "]";
  if (cfg.clusterVertices < 3 || cfg.clusterVertices > 255) return "clusterVertices must be in [3, 255]";
  if (cfg.groupClusters < 2 || cfg.groupClusters > 1u << 30) return "groupClusters must be in [2, 2^30]";
  if (!(cfg.stuckRatio > 0.0f && cfg.stuckRatio < 1.0f)) return "stuckRatio must be in (0, 1)";
  if (!(cfg.normalWeight >= 0.0f && std::isfinite(cfg.normalWeight))) return "normalWeight must be finite and >= 0";
  if (cfg.rootClusters < 1) return "rootClusters must be at least 1";
  if (mesh.indices.size() % 3 != 0) return "index count is not a multiple of 3";
  for (uint32_t i : mesh.indices)
    if (i >= mesh.positions.size()) return "index out of range";
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) return "normals size mismatch";
  if (!mesh.uv0.empty() && mesh.uv0.size() != mesh.positions.size()) return "uv0 size mismatch";
  for (const glm::vec3& p : mesh.positions)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return "non-finite position";
  return {};
}

} // namespace

Result<ClusterDag> buildClusterDag(const Mesh& mesh, const BuildConfig& cfg) {
  return buildClusterDag(mesh, cfg, nullptr);
}

Result<ClusterDag> buildClusterDag(const Mesh& mesh, const BuildConfig& cfg, std::vector<uint32_t>* sourceClusters) {
  std::string problem = checkConfig(mesh, cfg);
  if (!problem.empty()) return makeError(mesh.name.empty() ? "mesh" : mesh.name, problem);
  try {
    auto start = std::chrono::steady_clock::now();
    ClusterDag dag;
    std::vector<uint32_t> triangles;
    KeptSources kept;
    dag.normals = mesh.normals;
    dag.uv0 = mesh.uv0;
    // Weld and clean inside the arena too, so --threads bounds the whole build.
    tbb::task_arena arena(cfg.threads ? int(cfg.threads) : tbb::task_arena::automatic);
    arena.execute([&] {
      std::optional<WallTimer> wall(kWallPrep);
      std::optional<StageTimer> timer(kPrep);
      Welded welded = weldPositions(mesh.positions);
      triangles = cleanTriangles(mesh.indices, welded.vertexPosition, sourceClusters ? &kept : nullptr);
      if (sourceClusters) sourceClusters->assign(mesh.indices.size() / 3, kNone);
      timer.reset();
      wall.reset();
      dag.positions = std::move(welded.positions);
      dag.vertexPosition = std::move(welded.vertexPosition);
      dag.inputTriangles = triangles.size() / 3;
      Builder(dag, cfg, start).run(std::move(triangles), std::move(kept), sourceClusters);
    });
    printStages(dag.inputTriangles);
    return dag;
  } catch (const std::exception& e) {
    // Only allocation failures are expected here; never let them cross the library boundary.
    return makeError(mesh.name.empty() ? "mesh" : mesh.name, std::string("build failed: ") + e.what());
  }
}

} // namespace mirage::lod
