// Cluster splitter: greedy growth over shared vertices. Replaces meshopt_buildMeshlets, which was
// a third of the build (it allocates per call, builds its own adjacency and a kd-tree, and scores
// every triangle around the meshlet at every step). Our inputs are small compact patches (a
// simplified group, or a Morton-sorted level-0 chunk), so topology alone gives full clusters.
#include <algorithm>
#include <limits>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "partition.h"

namespace mirage::lod::detail {

namespace {

constexpr uint32_t kNil = ~0u;
// TriState::parts: corners outside the cluster (bits 0-1), corners with one live triangle left
// (bits 2-3), has a repeated vertex (bit 4).
constexpr uint32_t kRepeated = 16;
// Score rank by parts & 15: no vertex added 0, dangling (some corner's last live triangle) 1,
// else vertices added + 1.
constexpr uint32_t kRank[16] = {0, 2, 3, 4, 0, 1, 1, 1, 0, 1, 1, 1, 0, 1, 1, 1};
constexpr float kInf = std::numeric_limits<float>::infinity();

// The first triangle (in index order) whose centroid (x, y, z: blocks of four, +inf x for the
// triangles to skip) is nearest to c among blocks [firstBlock, blockCount), or kNil when none is
// nearer than FLT_MAX. The squared distance is glm::dot's, (dx² + dy²) + dz², lane by lane.
uint32_t nearestCentroid(const float* x, const float* y, const float* z, size_t firstBlock, size_t blockCount,
                         glm::vec3 c) {
  float bestD = std::numeric_limits<float>::max();
  uint32_t best = kNil;
#if defined(__SSE2__)
  const __m128 cx = _mm_set1_ps(c.x), cy = _mm_set1_ps(c.y), cz = _mm_set1_ps(c.z);
  // Per lane, its first smallest distance and that triangle's block (its first triangle).
  __m128 laneD = _mm_set1_ps(kInf);
  __m128i laneBlock = _mm_setzero_si128(), block = _mm_set1_epi32(int32_t(firstBlock * 4)), step = _mm_set1_epi32(4);
  for (size_t b = firstBlock; b < blockCount; ++b) {
    __m128 dx = _mm_sub_ps(_mm_loadu_ps(x + b * 4), cx);
    __m128 dy = _mm_sub_ps(_mm_loadu_ps(y + b * 4), cy);
    __m128 dz = _mm_sub_ps(_mm_loadu_ps(z + b * 4), cz);
    __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    __m128i nearer = _mm_castps_si128(_mm_cmplt_ps(d2, laneD));
    laneD = _mm_min_ps(d2, laneD);
    laneBlock = _mm_or_si128(_mm_and_si128(nearer, block), _mm_andnot_si128(nearer, laneBlock));
    block = _mm_add_epi32(block, step);
  }
  alignas(16) float d[4];
  alignas(16) uint32_t first[4];
  _mm_store_ps(d, laneD);
  _mm_store_si128(reinterpret_cast<__m128i*>(first), laneBlock);
  // Across lanes: the smallest distance, ties to the lower triangle (none at or past FLT_MAX).
  for (uint32_t lane = 0; lane < 4; ++lane)
    if (d[lane] < bestD || (d[lane] == bestD && best != kNil && first[lane] + lane < best))
      bestD = d[lane], best = first[lane] + lane;
#else
  for (size_t t = firstBlock * 4; t < blockCount * 4; ++t) {
    glm::vec3 v = glm::vec3(x[t], y[t], z[t]) - c;
    float d2 = glm::dot(v, v);
    if (d2 < bestD) bestD = d2, best = uint32_t(t);
  }
#endif
  return best;
}

// The first slot holding the lowest of score[0..count) (count > 0). Scores are below 0x7fff, and
// score has 8 spare entries past count (overwritten here). The scan runs once per added triangle
// over every candidate, so 16-bit scores, eight to a vector.
size_t firstLowest(uint16_t* score, size_t count) {
#if defined(__SSE2__)
  for (size_t i = count; i < count + 8; ++i) score[i] = 0x7fff;
  size_t blocks = (count + 7) / 8;
  auto block = [&](size_t b) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(score + b * 8)); };
  __m128i m = block(0);
  for (size_t b = 1; b < blocks; ++b) m = _mm_min_epi16(m, block(b));
  m = _mm_min_epi16(m, _mm_shuffle_epi32(m, 0x4e));
  m = _mm_min_epi16(m, _mm_shuffle_epi32(m, 0xb1));
  m = _mm_min_epi16(m, _mm_shufflelo_epi16(m, 0xb1));
  __m128i lowest = _mm_set1_epi16(int16_t(_mm_extract_epi16(m, 0)));
  for (size_t b = 0;; ++b)
    if (int mask = _mm_movemask_epi8(_mm_cmpeq_epi16(block(b), lowest)))
      return b * 8 + size_t(__builtin_ctz(uint32_t(mask))) / 2;
#else
  uint16_t lowest = *std::min_element(score, score + count);
  size_t i = 0;
  while (score[i] != lowest) ++i;
  return i;
#endif
}

} // namespace

ClusterSet splitClusters(const std::vector<uint32_t>& triangles, const std::vector<glm::vec3>& positions,
                         const std::vector<uint32_t>& vertexPosition, uint32_t maxVertices, uint32_t maxTriangles,
                         SplitScratch& s, std::vector<uint32_t>* emittedOut, const uint32_t* cornerPositions) {
  ClusterSet out;
  if (emittedOut) emittedOut->clear();
  size_t nt = triangles.size() / 3;
  if (nt == 0) return out;
  // Compact local vertex ids through a flat map (reset afterwards), not a sort or a hash map.
  uint32_t maxId = *std::max_element(triangles.begin(), triangles.end());
  if (s.localOf.size() <= maxId) s.localOf.resize(size_t(maxId) + 1, kNil);
  s.global.clear();
  s.vertPos.clear();
  s.corners.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) {
    // Level-0 chunks name vertices all over the mesh: fetch the map entries ahead.
    if (i + 32 < triangles.size()) __builtin_prefetch(&s.localOf[triangles[i + 32]]);
    uint32_t& l = s.localOf[triangles[i]];
    if (l == kNil) {
      l = uint32_t(s.global.size()), s.global.push_back(triangles[i]);
      // Each vertex's position copied once (centroids and spheres read the copy, not the
      // mesh-wide arrays: those reads were scattered cache misses, three per triangle).
      s.vertPos.push_back(positions[cornerPositions ? cornerPositions[i] : vertexPosition[triangles[i]]]);
    }
    s.corners[i] = l;
  }
  for (uint32_t g : s.global) s.localOf[g] = kNil;
  size_t nv = s.global.size();

  // Vertex -> triangle adjacency (CSR).
  s.offsets.assign(nv + 1, 0);
  for (uint32_t v : s.corners) ++s.offsets[v + 1];
  for (size_t v = 0; v < nv; ++v) s.offsets[v + 1] += s.offsets[v];
  s.adjacency.resize(s.corners.size());
  s.fill.assign(s.offsets.begin(), s.offsets.end() - 1);
  for (size_t c = 0; c < s.corners.size(); ++c) s.adjacency[s.fill[s.corners[c]]++] = uint32_t(c / 3);

  // Centroids (3x: only compared) as three float arrays padded to whole blocks of four, for the
  // nearest-triangle scan; an emitted triangle's x becomes +inf, which takes it out of the scan.
  size_t blockCount = (nt + 3) / 4;
  s.centroids.resize(blockCount * 12);
  float* centroidX = s.centroids.data();
  float* centroidY = centroidX + blockCount * 4;
  float* centroidZ = centroidY + blockCount * 4;
  for (size_t t = 0; t < nt; ++t) {
    glm::vec3 c = s.vertPos[s.corners[t * 3]] + s.vertPos[s.corners[t * 3 + 1]] + s.vertPos[s.corners[t * 3 + 2]];
    centroidX[t] = c.x, centroidY[t] = c.y, centroidZ[t] = c.z;
  }
  for (size_t t = nt; t < blockCount * 4; ++t) centroidX[t] = centroidY[t] = centroidZ[t] = kInf;
  s.emitted.assign(nt, 0);
  s.vertStamp.assign(nv, kNil);
  s.live.resize(nv);
  // Per-triangle state in one 16-byte record: the neighbour updates below touch all of it, and
  // separate arrays cost a cache line each.
  s.tri.resize(nt);
  SplitScratch::TriState* tri = s.tri.data();
  uint32_t anyRepeated = 0, maxLive = 0;
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* v = &s.corners[t * 3];
    tri[t].stamp = kNil;
    tri[t].parts = v[0] == v[1] || v[1] == v[2] || v[0] == v[2] ? kRepeated : 0;
    anyRepeated |= tri[t].parts;
  }
  for (size_t v = 0; v < nv; ++v) s.live[v] = s.offsets[v + 1] - s.offsets[v], maxLive = std::max(maxLive, s.live[v]);
  // No triangle to rescore from scratch and live sums that stay below the score's 12 bits: a
  // live sum dropping by one lowers the score by one.
  const bool plainScores = anyRepeated == 0 && maxLive * 3 <= 0xfff;
  s.vertLocal.resize(nv);
  uint32_t cluster = 0, vertexCount = 0, triangleCount = 0;
  // Output through raw pointers, sized for the worst case first (every corner a new cluster
  // vertex) and trimmed at the end: push_back of 8-bit indices made the compiler reload the
  // vectors' ends after every store (a char store may alias anything).
  out.indices.resize(nt * 3);
  out.vertices.resize(nt * 3);
  uint8_t* outIndices = out.indices.data();
  uint32_t* outVertices = out.vertices.data();
  size_t indexCount = 0, vertexTotal = 0;
  if (s.points.size() < maxVertices) s.points.resize(maxVertices);
  glm::vec3* points = s.points.data();
  size_t scan = 0; // every triangle before it is emitted (see firstUnemitted)
  // Candidates: unemitted triangles touching the cluster (deduplicated per cluster by triStamp),
  // with their scores in a parallel array and each triangle's slot in candPos, so picking is a scan
  // over one contiguous array instead of three scattered per-triangle lookups per entry. Removal
  // swaps the last entry in, and ties go to the first slot: the order (and so every pick) is the
  // one the per-triangle version had.
  s.candidates.resize(nt);
  s.candScore.resize(nt + 8); // spare entries for firstLowest
  uint32_t* cand = s.candidates.data();
  uint16_t* candScore = s.candScore.data();
  size_t candCount = 0;
  // Raw pointers (not the scratch's vectors) so stores through them do not force the compiler to
  // reload every vector's data pointer.
  const uint32_t* corners = s.corners.data();
  uint32_t* adjacency = s.adjacency.data();
  const uint32_t* offsets = s.offsets.data();
  uint32_t* live = s.live.data();
  uint32_t* vertStamp = s.vertStamp.data();
  uint32_t* vertLocal = s.vertLocal.data();
  uint8_t* emitted = s.emitted.data();
  auto removeCandidate = [&](uint32_t t) {
    uint32_t at = tri[t].candPos;
    --candCount;
    cand[at] = cand[candCount], candScore[at] = candScore[candCount];
    tri[cand[at]].candPos = at;
  };

  // Lower is better: triangles adding no vertex, then dangling ones (the last unused triangle at
  // a vertex: left behind they become islands of a few triangles, as in meshoptimizer), then by
  // vertices added; ties go to the most enclosed triangle (fewest unused triangles around its
  // vertices), so clusters fill the pockets that earlier clusters left instead of growing as
  // discs that leave gaps between them.
  // Vertices t would add (distinct corners outside the cluster).
  auto verticesAdded = [&](uint32_t t) {
    const uint32_t* v = &corners[size_t(t) * 3];
    uint32_t v0 = v[0], v1 = v[1], v2 = v[2];
    return uint32_t(vertStamp[v0] != cluster) + uint32_t(vertStamp[v1] != cluster && v1 != v0) +
           uint32_t(vertStamp[v2] != cluster && v2 != v0 && v2 != v1);
  };
  // Incremental scores: a candidate's score depends only on its corners' live counts and cluster
  // membership, which change only at the corners of the triangle just added. Instead of rescoring
  // every triangle around those corners from scratch (three corner loads and six vertex lookups
  // each), a candidate keeps its parts -- corners outside the cluster, corners with one live
  // triangle left (packed in `parts`), the live sum -- and each change adjusts them; the score is
  // the same number. Triangles with a repeated vertex (never made by clean or the simplifier, but
  // allowed here) are rescored from scratch, where "vertices added" counts distinct vertices.
  auto partsScore = [&](const SplitScratch::TriState& ts) {
    return uint16_t(kRank[ts.parts & 15] << 12 | std::min<uint32_t>(ts.liveSum, 0xfff));
  };
  auto initParts = [&](uint32_t t) {
    SplitScratch::TriState& ts = tri[t];
    const uint32_t* v = &corners[size_t(t) * 3];
    if (ts.parts & kRepeated) {
      uint32_t l0 = live[v[0]], l1 = live[v[1]], l2 = live[v[2]];
      uint32_t dangling = (l0 == 1) | (l1 == 1) | (l2 == 1);
      ts.parts = kRepeated | verticesAdded(t) | dangling << 2;
      ts.liveSum = l0 + l1 + l2;
      return;
    }
    uint32_t outside = 0, dangling = 0, liveSum = 0;
    for (int k = 0; k < 3; ++k) {
      outside += vertStamp[v[k]] != cluster;
      dangling += live[v[k]] == 1;
      liveSum += live[v[k]];
    }
    ts.parts = outside | dangling << 2, ts.liveSum = liveSum;
  };
  // Each vertex's adjacency range keeps its unemitted triangles first (live[v] of them, in the
  // original order: an emitted triangle is removed by shifting the rest down), so the loops below
  // never test emitted triangles; the scans were a third of the splitter's time, mostly
  // mispredicted "already emitted" branches.
  auto addTriangle = [&](uint32_t t) __attribute__((always_inline)) {
    if (tri[t].stamp == cluster) removeCandidate(t); // not yet emitted: it is a candidate
    emitted[t] = 1;
    centroidX[t] = kInf;
    if (emittedOut) emittedOut->push_back(t);
    const uint32_t* tv = &corners[size_t(t) * 3];
    // One pass per corner: t leaves the corner's live triangles, and the triangles around it are
    // adjusted (one live triangle fewer; one corner fewer outside when the corner joins the
    // cluster) or, around a corner that joins, become candidates. Every unemitted triangle around
    // a cluster vertex is a candidate, so around a corner already in the cluster all are.
    for (int k = 0; k < 3; ++k) {
      uint32_t v = tv[k];
      bool joins = vertStamp[v] != cluster;
      if (joins) {
        vertStamp[v] = cluster;
        points[vertexCount] = s.vertPos[v];
        vertLocal[v] = vertexCount++;
        outVertices[vertexTotal++] = s.global[v];
      }
      uint32_t* list = adjacency + offsets[v];
      uint32_t left = --live[v], kept = 0;
      uint32_t delta = (left == 1 ? 1u << 2 : 0u) - (joins ? 1u : 0u); // parts change (mod 2^32)
      if (joins) {
        for (uint32_t i = 0; i <= left; ++i) {
          uint32_t n = list[i];
          if (n == t) continue;
          list[kept++] = n;
          SplitScratch::TriState& ts = tri[n];
          if (ts.stamp != cluster) {
            // A new candidate around a joining corner: its parts from scratch (corners of t not
            // visited yet are adjusted when they are).
            ts.stamp = cluster, ts.candPos = uint32_t(candCount), cand[candCount++] = n;
            initParts(n);
          } else if (ts.parts & kRepeated) {
            initParts(n);
          } else {
            --ts.liveSum;
            ts.parts += delta;
          }
          candScore[ts.candPos] = partsScore(ts);
        }
      } else if (delta == 0 && plainScores) {
        // The corner was in the cluster already, so every triangle around it is a candidate, and
        // only their live sums drop by one: so do their scores (the sums' low bits).
        for (uint32_t i = 0; i <= left; ++i) {
          uint32_t n = list[i];
          if (n == t) continue;
          list[kept++] = n;
          SplitScratch::TriState& ts = tri[n];
          --ts.liveSum;
          --candScore[ts.candPos];
        }
      } else {
        for (uint32_t i = 0; i <= left; ++i) {
          uint32_t n = list[i];
          if (n == t) continue;
          list[kept++] = n;
          SplitScratch::TriState& ts = tri[n];
          if (ts.parts & kRepeated) {
            initParts(n);
          } else {
            --ts.liveSum;
            ts.parts += delta;
          }
          candScore[ts.candPos] = partsScore(ts);
        }
      }
      list[left] = t;
      outIndices[indexCount++] = uint8_t(vertLocal[v]);
    }
    ++triangleCount;
  };
  // The first unemitted triangle (scan only moves forward; advanced when asked).
  auto firstUnemitted = [&]() {
    while (scan < nt && emitted[scan]) ++scan;
    return scan;
  };

  uint32_t seed = 0;
  size_t done = 0;
  while (done < nt) {
    ClusterPiece piece{uint32_t(vertexTotal), 0, uint32_t(indexCount), 0};
    vertexCount = triangleCount = 0;
    candCount = 0;
    glm::vec3 seedCenter(centroidX[seed], centroidY[seed], centroidZ[seed]);
    // One call of addTriangle (the seed's, then each pick's): called once, it is inlined, and the
    // locals it updates stay in registers instead of being reached through the closure.
    for (uint32_t pick = seed;;) {
      addTriangle(pick);
      if (triangleCount >= maxTriangles) break;
      uint32_t best = kNil;
      pick = kNil;
      if (vertexCount + 3 <= maxVertices) {
        // Every candidate fits: the first candidate with the lowest score.
        if (candCount) pick = cand[firstLowest(candScore, candCount)];
      } else {
        for (size_t i = 0; i < candCount; ++i)
          if (candScore[i] < best && vertexCount + (tri[cand[i]].parts & 3) <= maxVertices)
            best = candScore[i], pick = cand[i];
      }
      if (pick == kNil) {
        // Nothing adjacent fits: continue with the nearest unused triangle that fits, as
        // meshoptimizer does; otherwise the pockets between clusters become clusters of a few
        // triangles (fill fell to 65 %). Linear scan (the first of the nearest, in input order).
        if (vertexCount + 3 <= maxVertices) {
          // Any triangle fits (it adds at most three vertices): the nearest, four at a time.
          pick = nearestCentroid(centroidX, centroidY, centroidZ, firstUnemitted() / 4, blockCount, seedCenter);
        } else {
          float bestD = std::numeric_limits<float>::max();
          for (size_t t = firstUnemitted(); t < nt; ++t) {
            if (emitted[t]) continue;
            glm::vec3 d = glm::vec3(centroidX[t], centroidY[t], centroidZ[t]) - seedCenter;
            float d2 = glm::dot(d, d);
            if (d2 >= bestD) continue;
            if (vertexCount + verticesAdded(uint32_t(t)) <= maxVertices) bestD = d2, pick = uint32_t(t);
          }
        }
        if (pick == kNil) break;
      }
    }
    piece.vertexCount = vertexCount;
    piece.triangleCount = triangleCount;
    out.pieces.push_back(piece);
    out.bounds.push_back(boundingSphere(points, vertexCount));
    done += triangleCount;
    ++cluster;
    if (done == nt) break;
    // Next seed: the most enclosed unemitted triangle next to the cluster just made (the sweep
    // stays contiguous and closes pockets first), else the first unemitted one in input order.
    seed = kNil;
    uint32_t bestLive = kNil;
    for (size_t i = 0; i < candCount; ++i) {
      uint32_t t = cand[i];
      const uint32_t* v = &s.corners[size_t(t) * 3];
      uint32_t l = s.live[v[0]] + s.live[v[1]] + s.live[v[2]];
      if (l < bestLive) bestLive = l, seed = t;
    }
    if (seed == kNil) seed = uint32_t(firstUnemitted());
  }
  out.vertices.resize(vertexTotal);
  out.indices.resize(indexCount); // every triangle was emitted: nt * 3
  return out;
}

} // namespace mirage::lod::detail
