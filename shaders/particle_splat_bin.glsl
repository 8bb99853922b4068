// The binned splat's passes over the records (particle_splat.glsl; ParticleDraw::cmdSplat), one
// thread per record slot, both classifying as the atomic splat does:
// - MIRAGE_SPLAT_PHASE_COUNT: billboards listed; each splat's entries (one per eye and tile its
//   footprint's pixels overlap) counted per tile;
// - MIRAGE_SPLAT_PHASE_SCATTER (after particle_splat_scan.comp): each entry written into its
//   tile's list at the tile's first entry + a cursor; an entry past the room is splatted into
//   that tile's pixels directly (global atomics), so the room never changes the image.
// Included after a sums file.
#extension GL_KHR_shader_subgroup_ballot : require

layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SplatBinsRef { uint v[]; };
// ParticleSplatEntry[] as two 16-byte words each (two 128-bit stores).
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer SplatEntryWordsRef { uvec4 v[]; };

// atomicAdd(bins[index], 1) for each calling invocation, its previous value returned. Where many
// invocations of the subgroup hit one counter (a dense cloud on a few tiles), they take one
// atomic between them and consecutive values; lanes on distinct counters (a spread cloud) take
// one each: same-address atomics serialize in the memory system.
uint binAdd(uint index) {
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  for (;;) {
    uint first = subgroupBroadcastFirst(index);
    if (subgroupBallotBitCount(subgroupBallot(index == first)) < 2u) break; // uniform
    if (index == first) {
      // The lanes executing here count themselves (correct however the subgroup reconverges).
      uvec4 here = subgroupBallot(true);
      uint base = 0u;
      if (subgroupElect()) base = atomicAdd(bins.v[index], subgroupBallotBitCount(here));
      return subgroupBroadcastFirst(base) + subgroupBallotExclusiveBitCount(here);
    }
  }
  return atomicAdd(bins.v[index], 1u);
}

void main() {
  vec3 position;
  float size;
  vec4 c;
  bool count = push.phase == MIRAGE_SPLAT_PHASE_COUNT;
  if (splatClassify(splatRecordIndex(), /*list=*/count, position, size, c) != SPLAT_SPLAT) return;
  uint tiles = push.eyes * push.tilesX * push.tilesY;
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  for (uint e = 0; e < push.eyes; ++e) {
    SplatFootprint f;
    if (!splatFootprint(e, position, size, f) || any(greaterThan(f.first, f.last))) continue;
    ivec2 t0 = f.first / MIRAGE_SPLAT_TILE, t1 = f.last / MIRAGE_SPLAT_TILE;
    for (int ty = t0.y; ty <= t1.y; ++ty)
      for (int tx = t0.x; tx <= t1.x; ++tx) {
        uint tile = (e * push.tilesY + uint(ty)) * push.tilesX + uint(tx);
        uint at = binAdd(MIRAGE_SPLAT_BIN_HEADER + tile); // the count, then the cursor
        if (count) continue;
        uint slot = bins.v[MIRAGE_SPLAT_BIN_HEADER + tiles + tile] + at;
        if (slot < push.entryRoom) {
          SplatEntryWordsRef w = SplatEntryWordsRef(push.entryAddress);
          w.v[2u * slot] = floatBitsToUint(vec4(f.lo, f.hi));
          w.v[2u * slot + 1u] = uvec4(floatBitsToUint(vec2(f.depth, f.weight)), packUnorm2x16(c.rg), packUnorm2x16(c.ba));
        } else { // past the room: this tile's pixels of the footprint, directly
          ivec2 origin = ivec2(tx, ty) * MIRAGE_SPLAT_TILE;
          splatDirect(e, f, c, max(f.first, origin), min(f.last, origin + MIRAGE_SPLAT_TILE - 1));
        }
      }
  }
}
