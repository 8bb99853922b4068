#version 460
// The depth raster's queue (atlas_visibility_depth.comp): the large opaque triangles it queued,
// their 8 x 8 pixel tiles spread over as many workgroups as they need, as the blend queue spreads
// blended ones (cluster_blend_queue.comp, whose numbering this follows). Workgroup g takes tiles
// [g, g + 1) * MIRAGE_BLEND_QUEUE_GROUP_TILES; a binary search over the entries' first tiles finds
// the triangle of its first tile. Each round every thread tests one pixel of one tile with the
// raster's own edge functions and depth (cluster_raster_edges.glsl) and keeps the nearest sample
// by the raster's 64-bit atomicMax, so a queued triangle writes exactly what its cluster's
// workgroup would have.
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_shader_atomic_int64 : require
#include "cluster_common.glsl"

#include "cluster_raster_edges.glsl"

layout(local_size_x = MIRAGE_BLEND_QUEUE_TILE * MIRAGE_BLEND_QUEUE_TILE) in;

struct QueuedTriangle {
  EdgeWalk64 edges;
  vec2 lo, hi;    // the sample box
  uint tilesX;    // tiles per row of the box
  uint firstTile; // in the queue's tile numbering
  uint tiles;     // of its box
  uint id;        // visibility id
  bool drawn;
};

QueuedTriangle queuedTriangle(ClusterFrame f, BlendQueueTriangle q) {
  QueuedTriangle t;
  sampleBox(q.a, q.b, q.c, f.camera.viewport, t.lo, t.hi);
  t.tilesX = uint(ceil((t.hi.x - t.lo.x + 1.0) / MIRAGE_BLEND_QUEUE_TILE));
  t.firstTile = q.firstTile;
  t.tiles = q.tiles;
  t.id = q.id;
  // Facing was decided when it was queued (keepsFacingExact): here only the orientation.
  t.drawn = edgeSetup64(q.a, q.b, q.c, t.lo, uvec2(1), /*keepAll=*/true, /*mirrored=*/false, t.edges);
  return t;
}

void main() {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  uint64_t counts = CounterRef(push.counterAddress).counters.blendQueueCounts;
  uint entries = uint(counts >> 32), tiles = uint(counts);
  uint first = (gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x) * MIRAGE_BLEND_QUEUE_GROUP_TILES;
  if (first >= tiles) return; // uniform over the workgroup
  uint end = min(first + MIRAGE_BLEND_QUEUE_GROUP_TILES, tiles);
  BlendQueueRef queue = BlendQueueRef(f.blendQueueAddress);
  uint entry = 0, last = entries - 1; // the last entry whose first tile is <= first
  while (entry < last) {
    uint mid = (entry + last + 1) / 2;
    if (queue.triangles[mid].firstTile <= first)
      entry = mid;
    else
      last = mid - 1;
  }
  uint row = uint(f.camera.viewport.x);
  uvec2 lane = uvec2(gl_LocalInvocationIndex % MIRAGE_BLEND_QUEUE_TILE, gl_LocalInvocationIndex / MIRAGE_BLEND_QUEUE_TILE);
  QueuedTriangle t = queuedTriangle(f, queue.triangles[entry]);
  for (uint tile = first; tile < end; ++tile) {
    while (tile - t.firstTile >= t.tiles) t = queuedTriangle(f, queue.triangles[++entry]); // uniform
    uint k = tile - t.firstTile;
    uvec2 local = uvec2(k % t.tilesX, k / t.tilesX) * MIRAGE_BLEND_QUEUE_TILE + lane;
    i64vec3 w = t.edges.w0 + t.edges.dx * int64_t(local.x) + t.edges.dy * int64_t(local.y);
    float z = edgeDepth(vec3(w), t.edges.zw);
    uvec2 p = uvec2(t.lo) + local;
    if (t.drawn && p.x <= uint(t.hi.x) && p.y <= uint(t.hi.y) && edgeInside(w) && z >= 0.0) // z < 0: beyond far
      atomicMax(VisBufferRef(push.visBufferAddress).pixels[p.y * row + p.x],
                (uint64_t(floatBitsToUint(z)) << 32) | uint64_t(t.id));
  }
}
