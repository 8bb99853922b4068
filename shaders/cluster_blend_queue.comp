#version 460
// Blend queue (docs/render.md, "Blend rasters"): the large blended triangles the compute blend
// raster queued (cluster_raster.glsl, blendEnqueue), their 8 x 8 pixel tiles spread over as many
// workgroups as they need. Workgroup g takes tiles [g, g + 1) * MIRAGE_BLEND_QUEUE_GROUP_TILES of
// the frame's tile numbering: a binary search over the entries' first tiles finds the triangle of
// its first tile, the following ones step on in order; each round every thread tests one pixel of
// one tile. Coverage, depth and the per-sample test are the compute blend raster's own functions
// (cluster_raster_edges.glsl, cluster_blend_sample.glsl), so a queued triangle gives exactly the
// fragments its cluster's workgroup would have. Nodes: each thread first tests its pixels of all
// the workgroup's tiles and counts each kept one on its pixel (oitCountFragment: under the pixel's
// cap or past it), then each subgroup takes one run of nodes for all its fragments under their cap
// (one counter atomic: oitAllocateSubgroup) and, tile by tile, its lanes link theirs with
// atomicExchange on the pixel's head onto consecutive nodes (coalesced node writes); fragments past
// their cap replace their pixel's farthest or are dropped (oitSlotOf). Packed storage
// (MIRAGE_FRAME_OIT_PACKED): each kept pixel is counted or written in the first round
// (oitPackedAppend: its range, or its fixed slots), and the second is skipped.
// Pushed: the blend list (ids name its entries) and the mono frame, or stereo's left eye frame.
#extension GL_EXT_nonuniform_qualifier : require
#include "cluster_common.glsl"

#include "cluster_raster_edges.glsl"
#include "cluster_blend_sample.glsl"

layout(local_size_x = MIRAGE_BLEND_QUEUE_TILE * MIRAGE_BLEND_QUEUE_TILE) in;

// One queued triangle ready to test pixels: its edge functions from its box's first sample.
struct QueuedTriangle {
  EdgeWalk64 edges;
  vec2 lo, hi;    // the sample box within the eye
  uint tilesX;    // tiles per row of the box
  uint firstTile; // in the frame's tile numbering
  uint tiles;     // of its box
  uint eyeX;      // target column of the eye's pixel 0 (stereo's right eye: the viewport's width)
  float fade;     // mixed scenes: the instance's surfel fade
  uint id;        // visibility id
  bool drawn;
};

QueuedTriangle queuedTriangle(ClusterFrame f, BlendQueueTriangle q) {
  QueuedTriangle t;
  sampleBox(q.a, q.b, q.c, f.camera.viewport, t.lo, t.hi);
  t.tilesX = uint(ceil((t.hi.x - t.lo.x + 1.0) / MIRAGE_BLEND_QUEUE_TILE));
  t.firstTile = q.firstTile;
  t.tiles = q.tiles & ~MIRAGE_BLEND_QUEUE_EYE;
  t.eyeX = (q.tiles & MIRAGE_BLEND_QUEUE_EYE) != 0 ? uint(f.camera.viewport.x) : 0u;
  t.id = q.id;
  uint instance = VisibleRef(push.visibleAddress).visible[(q.id >> MIRAGE_CLUSTER_TRIANGLE_BITS) - 1].instance;
  t.fade = f.fadeAddress == 0 ? 0.0 : instanceFade(instance);
  // Facing was decided when it was queued (keepsFacingExact): here only the orientation.
  t.drawn = edgeSetup64(q.a, q.b, q.c, t.lo, uvec2(1), /*keepAll=*/true, /*mirrored=*/false, t.edges);
  return t;
}

// This thread's pixel of tile `tile` of triangle t (within the eye; may lie past the box), its
// edge values there and its depth.
uvec2 tilePixel(QueuedTriangle t, uint tile, out i64vec3 w, out float z) {
  uint k = tile - t.firstTile;
  uvec2 local =
      uvec2(k % t.tilesX, k / t.tilesX) * MIRAGE_BLEND_QUEUE_TILE +
      uvec2(gl_LocalInvocationIndex % MIRAGE_BLEND_QUEUE_TILE, gl_LocalInvocationIndex / MIRAGE_BLEND_QUEUE_TILE);
  w = t.edges.w0 + t.edges.dx * int64_t(local.x) + t.edges.dy * int64_t(local.y);
  z = edgeDepth(vec3(w), t.edges.zw);
  return uvec2(t.lo) + local;
}

void main() {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if (!oitBeginBlendPass(f)) return; // uniform (cluster_args.comp dispatches none of these workgroups then)
  uint64_t counts = CounterRef(push.counterAddress).counters.blendQueueCounts;
  uint entries = uint(counts >> 32), tiles = uint(counts);
  uint first = (gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x) * MIRAGE_BLEND_QUEUE_GROUP_TILES;
  if (first >= tiles) return; // uniform over the workgroup
  uint end = min(first + MIRAGE_BLEND_QUEUE_GROUP_TILES, tiles);
  BlendQueueRef queue = BlendQueueRef(f.blendQueueAddress);
  uint firstEntry = 0, last = entries - 1; // the last entry whose first tile is <= first
  while (firstEntry < last) {
    uint mid = (firstEntry + last + 1) / 2;
    if (queue.triangles[mid].firstTile <= first)
      firstEntry = mid;
    else
      last = mid - 1;
  }
  // Every tile: this thread's pixel tested, kept ones as bits (tile - first), those under their
  // pixel's cap too.
  uint kept = 0, under = 0, entry = firstEntry;
  uint row = targetRowPixels(f);
  bool packed = oitPacked(f);
  QueuedTriangle t = queuedTriangle(f, queue.triangles[entry]);
  for (uint tile = first; tile < end; ++tile) {
    while (tile - t.firstTile >= t.tiles) t = queuedTriangle(f, queue.triangles[++entry]); // uniform
    i64vec3 w;
    float z;
    uvec2 p = tilePixel(t, tile, w, z);
    if (t.drawn && p.x <= uint(t.hi.x) && p.y <= uint(t.hi.y) && edgeInside(w) &&
        blendSampleKept(f, t.fade, t.eyeX, p.x, p.y, z)) {
      kept |= 1u << (tile - first);
      if (packed)
        oitPackedAppend(f, p.y * row + p.x + t.eyeX, z, t.id);
      else if (oitCountFragment(f.oitHeadAddress, p.y * row + p.x + t.eyeX) < MIRAGE_OIT_MAX_LAYERS)
        under |= 1u << (tile - first);
    }
  }
  if (packed) return; // uniform
  // One run of nodes per subgroup for its fragments under their cap, then tile by tile each kept
  // pixel onto its list.
  uint node = oitAllocateSubgroup(f.oitCounterAddress, subgroupAdd(uint(bitCount(under))));
  entry = firstEntry;
  t = queuedTriangle(f, queue.triangles[entry]);
  for (uint tile = first; tile < end; ++tile) {
    while (tile - t.firstTile >= t.tiles) t = queuedTriangle(f, queue.triangles[++entry]); // uniform
    bool keep = ((kept >> (tile - first)) & 1u) != 0, fresh = ((under >> (tile - first)) & 1u) != 0;
    uvec4 ballot = subgroupBallot(fresh);
    if (keep) {
      i64vec3 w;
      float z;
      uvec2 p = tilePixel(t, tile, w, z);
      uint pixel = p.y * row + p.x + t.eyeX;
      OitSlot s = oitSlotOf(fresh ? node + subgroupBallotExclusiveBitCount(ballot) : kOitNoNode, f.oitHeadAddress,
                            f.oitNodeAddress, f.oitNodeCapacity, pixel, z);
      if (s.node != kOitNoNode) oitCommit(f.oitHeadAddress, f.oitNodeAddress, pixel, s, z, t.id, /*payload=*/false);
    }
    node += subgroupBallotBitCount(ballot);
  }
}
