// The binned splat's passes over the records (particle_splat.glsl; ParticleDraw::cmdSplat), both
// classifying as the atomic splat does; a workgroup takes MIRAGE_PARTICLE_DRAW_GROUP x
// MIRAGE_SPLAT_BIN_RECORDS record slots:
// - MIRAGE_SPLAT_PHASE_COUNT: billboards listed; each splat's entries (one per eye and tile its
//   footprint's pixels overlap) counted per tile;
// - MIRAGE_SPLAT_PHASE_SCATTER (after particle_splat_scan.comp): each entry written into its
//   tile's list (the footprint, depth and colour: splatPack) at the tile's first entry + a cursor;
//   an entry past the room is splatted into that tile's pixels directly (global atomics), so the
//   room never changes the image.
// The count counts the workgroup's entries per tile in a shared table, and a tile's counter takes
// one global atomic per workgroup; the table is kept (push.tableAddress, 16 KB per workgroup), and
// the scatter's workgroup of the same records loads it, reserves its run of each tile's list at
// once and places its entries by shared cursors. Tiles that find no free slot in the table take
// the global atomics per entry (binAdd). Included after a sums file.
#extension GL_KHR_shader_subgroup_ballot : require

layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SplatBinsRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer SplatEntryRef { uvec4 v[]; };

#define SPLAT_NO_SLOT 0xffffffffu
shared uint slotTile[MIRAGE_SPLAT_BIN_SLOTS];  // the tile a slot counts, or SPLAT_NO_SLOT
shared uint slotCount[MIRAGE_SPLAT_BIN_SLOTS]; // its entries; in the scatter's second loop, its next list index

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

// The table's slot of `tile`, taken for it where `insert` finds a free one among its probes;
// SPLAT_NO_SLOT where every probe holds another tile. Tiles only ever enter the table, so every
// entry of one tile finds the same answer, in either pass (the scatter looks the count's table up).
uint binSlot(uint tile, bool insert) {
  uint slots = 1u << push.binSlotBits;
  uint s = push.binSlotBits == 0u ? 0u : (tile * 0x9E3779B1u) >> (32u - push.binSlotBits); // Fibonacci hashing
  for (uint i = 0u; i < min(MIRAGE_SPLAT_BIN_PROBES, slots); ++i, s = (s + 1u) & (slots - 1u)) {
    uint held = insert ? atomicCompSwap(slotTile[s], SPLAT_NO_SLOT, tile) : slotTile[s];
    if (held == tile || (insert && held == SPLAT_NO_SLOT)) return s;
    if (held == SPLAT_NO_SLOT) break; // looked up: never entered
  }
  return SPLAT_NO_SLOT;
}

#define SPLAT_LOOP_COUNT 0u // count pass: count in the table (or globally past it)
#define SPLAT_LOOP_WRITE 1u // scatter: write each entry at its place

// Global record g's entries, as `loop` does with them.
void binRecord(uint g, uint loop) {
  vec3 position;
  float size;
  vec4 c;
  if (splatClassify(g, /*list=*/loop == SPLAT_LOOP_COUNT, /*shade=*/loop == SPLAT_LOOP_WRITE, position, size, c) != SPLAT_SPLAT) return;
  uint tiles = push.eyes * push.tilesX * push.tilesY;
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  for (uint e = 0; e < push.eyes; ++e) {
    SplatFootprint f;
    if (!splatFootprint(e, position, size, f) || any(greaterThan(f.first, f.last))) continue;
    ivec2 t0 = f.first / MIRAGE_SPLAT_TILE, t1 = f.last / MIRAGE_SPLAT_TILE;
    for (int ty = t0.y; ty <= t1.y; ++ty)
      for (int tx = t0.x; tx <= t1.x; ++tx) {
        uint tile = (e * push.tilesY + uint(ty)) * push.tilesX + uint(tx);
        uint s = binSlot(tile, /*insert=*/loop == SPLAT_LOOP_COUNT);
        if (loop == SPLAT_LOOP_COUNT) {
          if (s != SPLAT_NO_SLOT) atomicAdd(slotCount[s], 1u);
          else binAdd(MIRAGE_SPLAT_BIN_HEADER + tile);
          continue;
        }
        uint slot = s != SPLAT_NO_SLOT ? atomicAdd(slotCount[s], 1u)
                                       : bins.v[MIRAGE_SPLAT_BIN_HEADER + tiles + tile] +
                                             binAdd(MIRAGE_SPLAT_BIN_HEADER + tile); // the cursor
        ivec2 origin = ivec2(tx, ty) * MIRAGE_SPLAT_TILE;
        if (slot < push.entryRoom) SplatEntryRef(push.entryAddress).v[slot] = splatPack(f, c, origin);
        else splatDirect(e, f, c, max(f.first, origin), min(f.last, origin + MIRAGE_SPLAT_TILE - 1)); // past the room
      }
  }
}

// A workgroup's table as the count leaves it for the scatter: per slot (tile, count).
layout(buffer_reference, std430, buffer_reference_align = 8) buffer SplatTableRef { uvec2 slots[]; };

void main() {
  uint i = gl_LocalInvocationID.x;
  uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  // The workgroup's records, consecutive per step (the record reads coalesce).
  uint first = group * (MIRAGE_PARTICLE_DRAW_GROUP * MIRAGE_SPLAT_BIN_RECORDS) + i;
  bool count = push.phase == MIRAGE_SPLAT_PHASE_COUNT;
  SplatTableRef table = SplatTableRef(push.tableAddress + uint64_t(group) * (MIRAGE_SPLAT_BIN_SLOTS * 8u));
  if (count) { // the entries counted per tile in the table
    for (uint s = i; s < MIRAGE_SPLAT_BIN_SLOTS; s += MIRAGE_PARTICLE_DRAW_GROUP) {
      slotTile[s] = SPLAT_NO_SLOT;
      slotCount[s] = 0u;
    }
    barrier();
    for (uint k = 0u; k < MIRAGE_SPLAT_BIN_RECORDS; ++k) binRecord(first + k * MIRAGE_PARTICLE_DRAW_GROUP, SPLAT_LOOP_COUNT);
  } else { // the table as the count left it (the same records, the same entries)
    for (uint s = i; s < MIRAGE_SPLAT_BIN_SLOTS; s += MIRAGE_PARTICLE_DRAW_GROUP) {
      uvec2 slot = table.slots[s];
      slotTile[s] = slot.x;
      slotCount[s] = slot.y;
    }
  }
  barrier();
  // Each tile of the table: its count added to the tile's and the table kept for the scatter
  // (count), or its run of the tile's list reserved, the slot's count becoming the run's first
  // index (scatter).
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  uint tiles = push.eyes * push.tilesX * push.tilesY;
  for (uint s = i; s < MIRAGE_SPLAT_BIN_SLOTS; s += MIRAGE_PARTICLE_DRAW_GROUP) {
    uint tile = slotTile[s], n = slotCount[s];
    if (count) table.slots[s] = uvec2(tile, n);
    if (tile == SPLAT_NO_SLOT || n == 0u) continue;
    uint at = atomicAdd(bins.v[MIRAGE_SPLAT_BIN_HEADER + tile], n);
    if (!count) slotCount[s] = bins.v[MIRAGE_SPLAT_BIN_HEADER + tiles + tile] + at;
  }
  if (count) return;
  barrier();
  for (uint k = 0u; k < MIRAGE_SPLAT_BIN_RECORDS; ++k) binRecord(first + k * MIRAGE_PARTICLE_DRAW_GROUP, SPLAT_LOOP_WRITE);
}
