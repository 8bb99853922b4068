// Body of the compute visibility's marking rasters (atlas_visibility_mark.comp, and
// atlas_visibility_mark_mask.comp with the alpha test of MASK clusters): the cluster renderer's
// compute raster (cluster_raster.glsl with MIRAGE_RASTER_MARK) walks the clusters again after the
// opaque raster, and every covered sample not behind the nearest depth that raster left in the
// 64-bit buffer, less MIRAGE_ATLAS_DEPTH_TOLERANCE of it, sets its patch's bit. BLEND samples in
// front count (every layer of glass); OPAQUE and MASK samples count where they are the nearest or
// tie with it within the tolerance: surfaces meeting or coplanar there, where the client's own
// rasterizer may round the other way and show this one. The tables come through
// ClusterPush::visibleInstanceAddress, which the raster kernels do not otherwise read.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_control_flow_attributes : require
#define MIRAGE_RASTER_MARK 1
#include "cluster_common.glsl"
#include "mirage/shaderio/atlas_shading.h"

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer AtlasTablesRef {
  AtlasVisibilityTables t;
};
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer AtlasUintRef { uint data[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer AtlasBitsRef { uint bits[]; };

uint atlasPatchOfId(AtlasVisibilityTables tables, uint id) {
  uint entry = (id >> MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u, t = id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
  uint triangle = AtlasUintRef(tables.entryTriangleAddress).data[entry] + t;
  return AtlasUintRef(tables.patchOfTriangleAddress).data[triangle];
}

// Most samples find their patch's bit already set: a plain read first, the atomic only for the first.
void atlasSetPatchBit(AtlasVisibilityTables tables, uint patchId) {
  AtlasBitsRef bits = AtlasBitsRef(tables.patchBitsAddress);
  uint bit = 1u << (patchId & 31u);
  if ((bits.bits[patchId >> 5] & bit) == 0) atomicOr(bits.bits[patchId >> 5], bit);
}

// A triangle's walk needs one sample that counts: its patch is looked up once, before the walk
// (sampleTarget), a triangle whose patch is already marked walks nothing, and the walk stops at the
// first sample that marks it (MIRAGE_RASTER_WALK_DONE in cluster_raster.glsl). Only hidden
// triangles, and visible ones up to their first counting sample, read the buffer.
bool markWalkDone; // this invocation's current walk

bool atlasPatchBitSet(AtlasVisibilityTables tables, uint patchId) {
  return (AtlasBitsRef(tables.patchBitsAddress).bits[patchId >> 5] & (1u << (patchId & 31u))) != 0;
}

// The patch of raster id `id`, and whether its walk is already done.
uint markWalkBegin(uint id) {
  AtlasVisibilityTables tables = AtlasTablesRef(push.visibleInstanceAddress).t;
  uint patchId = atlasPatchOfId(tables, id);
  markWalkDone = atlasPatchBitSet(tables, patchId);
  return patchId;
}

// Whether every sample of triangle a b c (screen x, y, reverse-Z depth) in depth tiles first..last
// lies behind those tiles less the tolerance, so that none marks: a tile's depth is at most any of
// its pixels' nearest, and a sample's depth at most its nearest corner's (with a margin for the
// interpolation's rounding).
bool markTilesHidden(vec3 a, vec3 b, vec3 c, uvec2 first, uvec2 last, ClusterFrame f) {
  uvec2 size = uvec2(f.camera.viewport);
  uint tilesX = (size.x + MIRAGE_ATLAS_DEPTH_TILE - 1) / MIRAGE_ATLAS_DEPTH_TILE;
  AtlasUintRef tiles = AtlasUintRef(push.visBufferAddress + uint64_t(size.x) * size.y * 8u);
  float nearest = max(a.z, max(b.z, c.z)) * (1.0 + 1.0 / 65536.0);
  for (uint y = first.y; y <= last.y; ++y)
    for (uint x = first.x; x <= last.x; ++x)
      if (nearest >= uintBitsToFloat(tiles.data[y * tilesX + x]) * (1.0 - MIRAGE_ATLAS_DEPTH_TOLERANCE)) return false;
  return true;
}

// The same over the depth tiles of box lo..hi, when there are few of them. Larger boxes are queued
// (cluster_raster.glsl) and tested tile by tile as the workgroup walks them (markQueuedTile).
bool markTriangleHidden(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, ClusterFrame f) {
  uvec2 first = uvec2(lo) / MIRAGE_ATLAS_DEPTH_TILE, last = uvec2(hi) / MIRAGE_ATLAS_DEPTH_TILE;
  if ((last.x - first.x + 1) * (last.y - first.y + 1) > MIRAGE_ATLAS_DEPTH_TILES_TESTED) return false;
  return markTilesHidden(a, b, c, first, last, f);
}

// A queued triangle's box in depth tiles: how many across and down (its raster tiles are these).
uvec2 markTileCount(vec2 lo, vec2 hi) {
  return uvec2(hi) / MIRAGE_ATLAS_DEPTH_TILE - uvec2(lo) / MIRAGE_ATLAS_DEPTH_TILE + 1u;
}
// Queued tile `tile` of box lo..hi: its samples' box (in tileLo..tileHi), or false when the walk
// can skip it (its patch is marked, or the triangle lies behind the tile).
bool markQueuedTile(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, uint tile, ClusterFrame f, out vec2 tileLo,
                    out vec2 tileHi) {
  uvec2 first = uvec2(lo) / MIRAGE_ATLAS_DEPTH_TILE;
  uint across = markTileCount(lo, hi).x;
  uvec2 t = first + uvec2(tile % across, tile / across);
  tileLo = max(vec2(t * MIRAGE_ATLAS_DEPTH_TILE), lo);
  tileHi = min(vec2(t * MIRAGE_ATLAS_DEPTH_TILE + (MIRAGE_ATLAS_DEPTH_TILE - 1)), hi);
  return !markWalkDone && !markTilesHidden(a, b, c, t, t, f);
}

void markSample(uint64_t nearest, float z, uint patchId) {
  if (z < uintBitsToFloat(uint(nearest >> 32)) * (1.0 - MIRAGE_ATLAS_DEPTH_TOLERANCE)) return; // behind it
  atlasSetPatchBit(AtlasTablesRef(push.visibleInstanceAddress).t, patchId);
  markWalkDone = true;
}

#include "cluster_raster.glsl"
