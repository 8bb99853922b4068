// Body of the compute software rasterizers (cluster_raster.comp: opaque clusters, and
// cluster_raster_mask.comp, MIRAGE_RASTER_MASK: masked ones, into the 64-bit visibility buffer;
// cluster_raster_blend.comp, MIRAGE_RASTER_BLEND: blended clusters into the transparency lists;
// atlas_visibility_mark*.comp, MIRAGE_RASTER_MARK: the streaming server's marking of visible patches;
// atlas_visibility_depth.comp, MIRAGE_RASTER_DEPTH_QUEUE: its depth raster, large triangles queued).
// One workgroup of 128 threads per eye per visible cluster (the renderer's kRasterLanes: one round
// of triangles per thread, and the driver fits the kernel in 64 registers, where 64 threads per
// eye took 79: on an H100, 2500 blobs raster 0.130 -> 0.092 ms, 2500 dragons 0.290 -> 0.220);
// each thread walks the pixel bounding box of its triangles
// (larger boxes are shared by the workgroup, see the queue below) with exact integer edge functions
// (see walkSmall) and keeps the nearest sample with a 64-bit atomicMax of
// (reverse-Z depth bits << 32 | ((visible index + 1) << 7 | triangle)): larger depth is nearer and
// positive float bits order like the floats. Vertices snap to 1/256 pixel and ties follow the
// top-left rule, as fixed-function hardware does, so the ids match the other backends.
// Triangles crossing the near plane are clipped against it in clip space (at most a quad, drawn as
// a two-triangle fan), so a camera inside or next to the geometry draws what the hardware draws.
// Stereo (kEyes = 2, the left eye's frame): each vertex is transformed once; the right eye's clip
// position is the left one's with x + stereoClipDx (y, z, w are the same), so only its screen x is
// kept too, and every triangle is drawn into both halves of the 2W-wide buffer (an eye whose
// bounding box misses its half loops over nothing). The workgroup doubles: its first half of
// threads draw the left eye, the others the right, so a thread walks as
// many triangles as in mono (the pass is bound by that serial walk, not by the vertex transform).
// Near-plane clipping is per eye for free: the near distance w - z is the same in both eyes.
// Lean kernel (cluster_raster_lean.comp, MIRAGE_RASTER_LEAN): the clusters the selection proved
// need nothing but the per-thread 32-bit walk (leanRasterCluster in cluster_common.glsl: not
// masked, wholly beyond the near plane, every triangle's box unqueued and its extent small) are
// drawn by that walk alone, with no queue, clipping, 64-bit or float walk, nor their registers
// and shared memory; it writes exactly the samples and values the general kernel would.
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_atomic_int64 : require
#include "cluster_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];

#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_alpha.glsl"
#include "cluster_raster_edges.glsl"

// Specialization: eyes drawn (1, or 2 for stereo), and the workgroup size, kEyes * threads per eye.
layout(constant_id = 0) const uint kEyes = 1;
layout(local_size_x_id = 1) in;

#ifndef MIRAGE_RASTER_LEAN
shared vec4 clipPos[MIRAGE_CLUSTER_MAX_VERTICES]; // clip space (only read for near-crossing triangles)
#endif
shared vec3 screen[MIRAGE_CLUSTER_MAX_VERTICES];  // pixels x, y; depth z/w
// Stereo: the right eye's pixel x. One element in the mono kernels, whose shared memory (and so
// workgroups per SM: the raster is latency-bound) stays as it was.
shared float screenRightX[kEyes == 2 ? MIRAGE_CLUSTER_MAX_VERTICES : 1];

uint visRowPixels; // pixels per row of the 64-bit buffer: the viewport's width, both eyes' in stereo

// Signed distance to the near plane in clip space: reverse-Z puts the near plane at z = w, so
// w - z >= 0 is in front of it (and w >= znear > 0 there, so the divide below is safe).
float nearDistance(vec4 clip) { return clip.w - clip.z; }

vec3 toScreen(vec4 clip, vec2 viewport) {
  vec3 ndc = clip.xyz / clip.w;
  vec2 px = (ndc.xy * 0.5 + 0.5) * viewport;
  return vec3(round(px * 256.0) / 256.0, ndc.z);
}

// A walk ends early where its triangle can add nothing more: the marking rasters stop once the
// triangle's patch is marked (markWalkDone, atlas_visibility_mark.glsl); the others walk every sample.
#ifdef MIRAGE_RASTER_MARK
#define MIRAGE_RASTER_WALK_DONE \
  if (markWalkDone) return;
#else
#define MIRAGE_RASTER_WALK_DONE
#endif

#if defined(MIRAGE_RASTER_BLEND)
#include "cluster_blend_sample.glsl"
#elif defined(MIRAGE_RASTER_MARK)
// The atlas's marking rasters (atlas_visibility_mark.glsl, which defines markSample): each covered
// sample is tested against the depth the opaque raster left in the 64-bit buffer, which they only read.
void writeSample(ClusterFrame f, uint x, uint y, float z, uint id) {
  markSample(VisBufferRef(push.visBufferAddress).pixels[y * visRowPixels + x], z, id);
}
#else
void writeSample(ClusterFrame f, uint x, uint y, float z, uint id) {
  countOverdraw(f, uvec2(x, y));
  uint64_t value = (uint64_t(floatBitsToUint(z)) << 32) | uint64_t(id);
  atomicMax(VisBufferRef(push.visBufferAddress).pixels[y * visRowPixels + x], value);
}
#endif

// Triangles whose pixel box exceeds MIRAGE_RASTER_SHARED_PIXELS are not walked by their own thread:
// one such triangle keeps its warp (and the dispatch's tail) waiting for hundreds of iterations
// while its neighbours cover a few pixels each. They queue here (triangle index | eye << 7), and
// after the per-thread pass the workgroup walks them in two ways (on an H100, 2500 blobs at tau 1:
// raster 0.130 ms against 0.160 with every box over 64 pixels walked as a lattice, stereo 0.123
// against 0.156; the largest boxes stay faster as a lattice, whose warps write neighbouring pixels):
// - boxes up to MIRAGE_RASTER_LATTICE_PIXELS are cut into 8 x 8 tiles, numbered on from the tiles
//   queued before them, and the threads take the tiles of all such triangles in turn, one tile
//   each (as much work as a per-thread box at most). One 64-bit counter (entries << 32 | tiles)
//   hands out both numbers at once, so first tiles grow with the entry index and a binary search
//   finds a tile's triangle;
// - larger boxes (coarse cuts, large tau, foveation's periphery), flagged, are walked one after
//   the other by each eye's threads as a lattice 8 pixels wide (8 x 16 blocks with 128 threads
//   per eye), each thread one pixel of every block.
// Queued triangles spanning under MIRAGE_RASTER_SMALL_EXTENT still walk 32-bit values
// (walkQueued): 64-bit integer arithmetic is emulated, twice the instructions or more.
// Boxes over MIRAGE_RASTER_SHARED_PIXELS (cluster_common.glsl) are queued.
#ifndef MIRAGE_RASTER_LEAN
#define MIRAGE_RASTER_TILE 8.0
#define MIRAGE_RASTER_LATTICE_PIXELS 512
#define MIRAGE_RASTER_LATTICE 8                 // lattice width; its height is the eye's threads / 8
#define MIRAGE_RASTER_QUEUE_LATTICE 0x80000000u // entry flag: walked as a lattice, no tiles
shared uint queuedTriangles[MIRAGE_CLUSTER_MAX_TRIANGLES * kEyes];
shared uint queuedFirstTile[MIRAGE_CLUSTER_MAX_TRIANGLES * kEyes];
shared uint64_t queuedCounts;
#endif

// What a covered sample of one triangle writes, and where (constant over the triangle's walk).
// `masked`: a constant per kernel, so the opaque one carries no alpha code; masked samples pass
// maskKeeps on `tri` (the unclipped triangle) seen from the frame at `eyeFrame`. Samples land
// `eyeX` pixels right of the eye's own pixel (stereo's right half).
struct SampleTarget {
  uint id;
  float fade;
  bool masked;
  ClusterTriangle tri;
  GpuMaterial m;
  uint64_t eyeFrame;
  uint eyeX;
};

void drawSample(ClusterFrame f, SampleTarget t, uint x, uint y, float z) {
#ifdef MIRAGE_RASTER_BLEND
  // The blend queue's test too (cluster_blend_sample.glsl); onto the pixel's list (cluster_oit.glsl).
  if (blendSampleKept(f, t.fade, t.eyeX, x, y, z)) oitAppend(f, x + t.eyeX, y, z, t.id);
#else
  if (z < 0.0) return;                              // beyond the far plane
  if (!meshKeepsPixel(t.fade, uvec2(x, y))) return; // the surfels' pixel in the blend band
  if (t.masked && !maskKeeps(FrameRef(t.eyeFrame).frame, t.m, t.tri, vec2(x, y) + 0.5)) return; // below the cutoff
  writeSample(f, x + t.eyeX, y, z, t.id);
#endif
}

// Samples (x + 0.5, y + 0.5) of the box lo..hi, 32-bit (extent under MIRAGE_RASTER_SMALL_EXTENT):
// every sample, or (lattice walks) the samples lattice + k * stride.
void walkSmall(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, vec2 lattice, uvec2 stride, bool keepAll, bool mirrored,
               ClusterFrame f, SampleTarget t) {
  MIRAGE_RASTER_WALK_DONE
  lo += lattice;
  vec2 o = (lo + 0.5) * MIRAGE_RASTER_SNAP; // the first sample: grid coordinates relative to it
  ivec2 A = ivec2(a.xy * MIRAGE_RASTER_SNAP - o), B = ivec2(b.xy * MIRAGE_RASTER_SNAP - o);
  ivec2 C = ivec2(c.xy * MIRAGE_RASTER_SNAP - o);
  int area = (B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x);
  if (!keepsFacing(float(area), keepAll, mirrored)) return;
  if (area < 0) { // orient so inside is positive for all three edges
    ivec2 tmp = B;
    B = C;
    C = tmp;
    vec3 tz = b;
    b = c;
    c = tz;
    area = -area;
  }
  // Edge (u, v) at sample p: (v.x - u.x)(p.y - u.y) - (v.y - u.y)(p.x - u.x); w.x weighs a, w.y b, w.z c.
  ivec3 ex = ivec3(C.x - B.x, A.x - C.x, B.x - A.x), ey = ivec3(C.y - B.y, A.y - C.y, B.y - A.y);
  ivec3 w0 = ivec3(ey.x * B.x - ex.x * B.y, ey.y * C.x - ex.y * C.y, ey.z * A.x - ex.z * A.y);
  w0 += ivec3(topLeft(ivec2(ex.x, ey.x)) ? 0 : -1, topLeft(ivec2(ex.y, ey.y)) ? 0 : -1,
              topLeft(ivec2(ex.z, ey.z)) ? 0 : -1);
  ivec3 dx = -ey * int(MIRAGE_RASTER_SNAP * stride.x), dy = ex * int(MIRAGE_RASTER_SNAP * stride.y);
  vec3 zw = vec3(a.z, b.z, c.z) / float(area);
  // Each row walks only the span its edges allow, not the whole box: a sliver's box is mostly
  // outside it, and a warp waits for its longest walk (H100, 2500 blobs: the box walks were 0.075 of
  // the raster's 0.09 ms). Edge i is inside from step -w_i / dx_i on (dx_i > 0) or up to step
  // w_i / -dx_i (dx_i < 0); the float quotients are rounded outwards (floor for the first step, one
  // more for the last), so the span holds every covered sample and the exact integer test below
  // still decides each one: the samples drawn are the box walk's.
  vec3 stepsPerValue = vec3(1.0) / vec3(dx);
  int steps = lo.x <= hi.x ? int((uint(hi.x) - uint(lo.x)) / stride.x) : -1; // the last step of a row
  for (uint y = uint(lo.y); y <= uint(hi.y); y += stride.y, w0 += dy) {
    int first = 0, last = steps;
    [[unroll]] for (int i = 0; i < 3; ++i) {
      float k = float(w0[i]) * stepsPerValue[i]; // -(first step inside) when dx > 0, the last one when dx < 0
      if (dx[i] > 0)
        first = max(first, int(floor(-k)));
      else if (dx[i] < 0)
        last = min(last, int(floor(-k)) + 1);
      else if (w0[i] < 0)
        last = -1; // parallel to the row and outside
    }
    ivec3 w = w0 + first * dx;
    uint x = uint(lo.x) + uint(first) * stride.x;
    for (int k = first; k <= last; ++k, x += stride.x, w += dx)
      if ((w.x | w.y | w.z) >= 0) {
        drawSample(f, t, x, y, edgeDepth(vec3(w), zw));
        MIRAGE_RASTER_WALK_DONE
      }
  }
}

#ifndef MIRAGE_RASTER_LEAN
// Samples of the box lo..hi (or lattice + k * stride), 64-bit (coordinates within
// MIRAGE_RASTER_LARGE_COORD): the tiles and lattices of larger queued triangles and the
// near-clipped triangles (the blend queue's threads evaluate the same functions per pixel).
// The facing test stays here, between the two set-up helpers, rather than behind edgeSetup64's
// early return: inlined three times, that return becomes a switch whose phis carry the 64-bit
// edge values through the kernel (H100, 2500 blobs: stereo raster 0.130 ms against 0.108).
void walkLarge(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, vec2 lattice, uvec2 stride, bool keepAll, bool mirrored,
               ClusterFrame f, SampleTarget t) {
  MIRAGE_RASTER_WALK_DONE
  vec2 first = lo + lattice;
  EdgeCorners64 k = edgeCorners64(a, b, c, first);
  if (!keepsFacing(float(k.area), keepAll, mirrored)) return;
  EdgeWalk64 e = edgeWalk64(k, a, b, c, stride);
  for (uint y = uint(first.y); y <= uint(hi.y); y += stride.y, e.w0 += e.dy) {
    i64vec3 w = e.w0;
    for (uint x = uint(first.x); x <= uint(hi.x); x += stride.x, w += e.dx)
      if (edgeInside(w)) {
        drawSample(f, t, x, y, edgeDepth(vec3(w), e.zw));
        MIRAGE_RASTER_WALK_DONE
      }
  }
}

float edge(vec2 a, vec2 b, vec2 p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); }
// An edge's function evaluated from its endpoints in one canonical order (by y, then x) and
// negated when (a, b) is the other order: two triangles sharing an edge then compute bit-identical
// values of opposite sign at every sample (the float products round, but identically).
struct Edge {
  vec2 u, v;
  float sign;
};
Edge canonicalEdge(vec2 a, vec2 b) {
  bool swap = a.y > b.y || (a.y == b.y && a.x > b.x);
  return Edge(swap ? b : a, swap ? a : b, swap ? -1.0 : 1.0);
}
float edgeAt(Edge e, vec2 p) { return e.sign * edge(e.u, e.v, p); }

// Every sample of the box lo..hi in floats: triangles reaching beyond MIRAGE_RASTER_LARGE_COORD.
void walkFloat(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, bool keepAll, bool mirrored, ClusterFrame f, SampleTarget t) {
  MIRAGE_RASTER_WALK_DONE
  float area = edge(a.xy, b.xy, c.xy);
  if (!keepsFacing(area, keepAll, mirrored)) return;
  if (area < 0.0) {
    vec3 tmp = b;
    b = c;
    c = tmp;
    area = -area;
  }
  bool tl0 = topLeft(c.xy - b.xy), tl1 = topLeft(a.xy - c.xy), tl2 = topLeft(b.xy - a.xy);
  Edge e0 = canonicalEdge(b.xy, c.xy), e1 = canonicalEdge(c.xy, a.xy), e2 = canonicalEdge(a.xy, b.xy);
  for (float y = lo.y; y <= hi.y; ++y) {
    for (float x = lo.x; x <= hi.x; ++x) {
      vec2 s = vec2(x + 0.5, y + 0.5);
      float w0 = edgeAt(e0, s), w1 = edgeAt(e1, s), w2 = edgeAt(e2, s);
      if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
      if ((w0 == 0.0 && !tl0) || (w1 == 0.0 && !tl1) || (w2 == 0.0 && !tl2)) continue;
      drawSample(f, t, uint(x), uint(y), (w0 * a.z + w1 * b.z + w2 * c.z) / area);
      MIRAGE_RASTER_WALK_DONE
    }
  }
}

// Samples lattice + k * stride of the box lo..hi of a queued triangle: 32-bit when the triangle
// spans under MIRAGE_RASTER_SMALL_EXTENT (64-bit integer arithmetic is emulated: twice the
// instructions), else 64-bit.
void walkQueued(vec3 a, vec3 b, vec3 c, vec2 lo, vec2 hi, vec2 lattice, uvec2 stride, bool keepAll, bool mirrored,
                ClusterFrame f, SampleTarget t) {
  vec2 extent = max(a.xy, max(b.xy, c.xy)) - min(a.xy, min(b.xy, c.xy));
  if (max(extent.x, extent.y) < MIRAGE_RASTER_SMALL_EXTENT)
    walkSmall(a, b, c, lo, hi, lattice, stride, keepAll, mirrored, f, t);
  else
    walkLarge(a, b, c, lo, hi, lattice, stride, keepAll, mirrored, f, t);
}

// Whether a triangle within MIRAGE_RASTER_LARGE_COORD is drawn, from its exact area (queued
// triangles that will not draw take no tiles).
bool keepsFacingExact(vec3 a, vec3 b, vec3 c, bool keepAll, bool mirrored) {
  i64vec2 A = i64vec2(a.xy * MIRAGE_RASTER_SNAP), B = i64vec2(b.xy * MIRAGE_RASTER_SNAP);
  i64vec2 C = i64vec2(c.xy * MIRAGE_RASTER_SNAP);
  return keepsFacing(float((B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x)), keepAll, mirrored);
}

#ifdef MIRAGE_RASTER_DEPTH_QUEUE
// Share of its box a triangle must cover to go to the depth raster's queue (a screen-filling quad's
// halves cover half of theirs).
const float kDepthQueueCover = 0.25;
#endif
#if defined(MIRAGE_RASTER_BLEND) || defined(MIRAGE_RASTER_DEPTH_QUEUE)
// The blend queue (docs/render.md, "Blend rasters"; the atlas server's depth raster queues its large
// opaque triangles the same way: atlas_visibility_depth.comp): a blended triangle whose box exceeds
// f.blendQueuePixels goes to one global queue, whose tiles the next dispatch spreads over many
// workgroups (cluster_blend_queue.comp), instead of keeping this cluster's workgroup walking up to a
// screenful of pixels while the GPU idles. Its slot and first tile come from one 64-bit
// compare-and-swap that refuses past the queue's capacity or the tile limit: then false, counted,
// and the caller walks it in this workgroup as without the queue.
bool blendEnqueue(ClusterFrame f, vec3 a, vec3 b, vec3 c, vec2 box, SampleTarget t) {
  uint tiles = uint(ceil(box.x / MIRAGE_BLEND_QUEUE_TILE)) * uint(ceil(box.y / MIRAGE_BLEND_QUEUE_TILE));
  CounterRef counters = CounterRef(push.counterAddress);
  uint64_t seen = counters.counters.blendQueueCounts, counts;
  do { // a stale first read only costs a retry: the swap returns the current value
    counts = seen;
    if (uint(counts >> 32) >= f.blendQueueCapacity || uint(counts) > MIRAGE_BLEND_QUEUE_MAX_TILES - tiles) {
      atomicAdd(counters.counters.blendQueueOverflow, 1);
      return false;
    }
    seen = atomicCompSwap(counters.counters.blendQueueCounts, counts, counts + ((uint64_t(1) << 32) | uint64_t(tiles)));
  } while (seen != counts);
  BlendQueueRef(f.blendQueueAddress).triangles[uint(counts >> 32)] =
      BlendQueueTriangle(a, b, c, t.id, tiles | (t.eyeX != 0 ? MIRAGE_BLEND_QUEUE_EYE : 0u), uint(counts));
  return true;
}
#endif

// One screen-space triangle (snapped vertices) into the 64-bit visibility buffer (or the
// transparency lists). A box over MIRAGE_RASTER_SHARED_PIXELS goes to the workgroup's queue as
// `queueEntry` instead (~0u: never); a blended one over ClusterFrame::blendQueuePixels to the blend
// queue first.
void rasterTriangle(vec3 a, vec3 b, vec3 c, bool keepAll, bool mirrored, ClusterFrame f, SampleTarget t,
                    uint queueEntry) {
  MIRAGE_RASTER_WALK_DONE // a marked patch's triangle takes no queue slot either
  vec2 lo, hi;
  sampleBox(a, b, c, f.camera.viewport, lo, hi);
  if (hi.x < lo.x || hi.y < lo.y) return; // off screen (or no sample centre inside)
#ifdef MIRAGE_RASTER_MARK
  if (markTriangleHidden(a, b, c, lo, hi, f)) return;
#endif
  vec2 mn = min(a.xy, min(b.xy, c.xy)), mx = max(a.xy, max(b.xy, c.xy));
  vec2 box = hi - lo + 1.0, extent = mx - mn;
  bool exact64 = max(max(abs(mn.x), abs(mn.y)), max(abs(mx.x), abs(mx.y))) < MIRAGE_RASTER_LARGE_COORD;
#if defined(MIRAGE_RASTER_BLEND) || defined(MIRAGE_RASTER_DEPTH_QUEUE)
  // Near-clipped fan triangles too: the queue keeps the screen corners, not the cluster's triangle.
  bool queueIt = exact64 && f.blendQueueAddress != 0 && box.x * box.y > f.blendQueuePixels;
#ifdef MIRAGE_RASTER_DEPTH_QUEUE
  // The queue tests every pixel of a box, the workgroup's walk only each row's span: slivers (long
  // thin triangles, a box mostly empty) stay here (on an H100, queued slivers took the untessellated
  // Sponza's depth raster from 1.6 to 75 ms).
  queueIt = queueIt && abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) >=
                           2.0 * kDepthQueueCover * box.x * box.y;
#endif
  if (queueIt) {
    if (!keepsFacingExact(a, b, c, keepAll, mirrored)) return;
    if (blendEnqueue(f, a, b, c, box, t)) return;
  }
#endif
  if (queueEntry != ~0u && exact64 && box.x * box.y > float(MIRAGE_RASTER_SHARED_PIXELS)) {
    if (!keepsFacingExact(a, b, c, keepAll, mirrored)) return;
#ifdef MIRAGE_RASTER_MARK
    // Marking: every queued box in the depth tiles' grid, tested tile by tile (markQueuedTile).
    bool lattice = false;
    uvec2 tiles = markTileCount(lo, hi);
#else
    bool lattice = box.x * box.y > float(MIRAGE_RASTER_LATTICE_PIXELS);
    uvec2 tiles = lattice ? uvec2(0) : uvec2(ceil(box / MIRAGE_RASTER_TILE));
#endif
    uint64_t counts = atomicAdd(queuedCounts, (uint64_t(1) << 32) | uint64_t(tiles.x * tiles.y));
    queuedTriangles[uint(counts >> 32)] = queueEntry | (lattice ? MIRAGE_RASTER_QUEUE_LATTICE : 0u);
    queuedFirstTile[uint(counts >> 32)] = uint(counts);
    return;
  }
  if (max(extent.x, extent.y) < MIRAGE_RASTER_SMALL_EXTENT)
    walkSmall(a, b, c, lo, hi, vec2(0.0), uvec2(1), keepAll, mirrored, f, t);
  else if (exact64)
    walkLarge(a, b, c, lo, hi, vec2(0.0), uvec2(1), keepAll, mirrored, f, t);
  else
    walkFloat(a, b, c, lo, hi, keepAll, mirrored, f, t);
}

#endif // !MIRAGE_RASTER_LEAN

// Triangle t's corners: their indices into the cluster's shared vertices, and their snapped screen
// positions as eye `eye` sees them (the right eye keeps its own x).
uvec3 triangleCorners(GpuCluster c, uint t) {
  uint b = (c.triangleOffset + t) * 3u;
  return uvec3(localIndex(b), localIndex(b + 1), localIndex(b + 2));
}
void eyeScreen(uvec3 i, uint eye, out vec3 s0, out vec3 s1, out vec3 s2) {
  s0 = screen[i.x];
  s1 = screen[i.y];
  s2 = screen[i.z];
  if (eye == 1) {
    s0.x = screenRightX[i.x];
    s1.x = screenRightX[i.y];
    s2.x = screenRightX[i.z];
  }
}

// What triangle t of visible cluster v writes, seen from eye `eye` (mono kernels pass 0).
SampleTarget sampleTarget(uint v, uint t, uint eye, float fade, bool masked, GpuCluster c, GpuClusterInstance inst,
                          GpuMaterial m, ClusterFrame f) {
  SampleTarget target;
  target.id = ((v + 1) << MIRAGE_CLUSTER_TRIANGLE_BITS) | t;
  target.fade = fade;
  target.masked = masked;
  if (masked) target.tri = fetchTriangle(c, inst, t);
  target.m = m;
  target.eyeFrame = push.frameAddress + eye * MIRAGE_CLUSTER_FRAME_STRIDE;
  target.eyeX = eye * uint(f.camera.viewport.x);
#ifdef MIRAGE_RASTER_MARK
  target.id = markWalkBegin(target.id); // the walk's samples mark this patch
#endif
  return target;
}

#ifdef MIRAGE_RASTER_LEAN
// The cluster's triangles (vertices already in shared memory), one per thread per round, each by
// the per-thread walk rasterTriangle would give it (the selection proved it unclipped, unqueued
// and under MIRAGE_RASTER_SMALL_EXTENT).
void rasterClusterLean(uint v, GpuCluster c, GpuClusterInstance inst, ClusterFrame f, float fade) {
  bool keepAll = (f.flags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 || (inst.flags & MIRAGE_INSTANCE_DOUBLE_SIDED) != 0;
  bool mirrored = (inst.flags & MIRAGE_INSTANCE_MIRRORED) != 0;
  GpuMaterial m; // unread: lean clusters are never masked
  const uint lanes = gl_WorkGroupSize.x / kEyes;
  uint eye = kEyes == 2 ? gl_LocalInvocationIndex / lanes : 0;
  uint lane = kEyes == 2 ? gl_LocalInvocationIndex % lanes : gl_LocalInvocationIndex;
  for (uint t = lane; t < c.triangleCount; t += lanes) {
    vec3 a, b, d;
    eyeScreen(triangleCorners(c, t), eye, a, b, d);
    vec2 lo, hi;
    sampleBox(a, b, d, f.camera.viewport, lo, hi);
    if (hi.x < lo.x || hi.y < lo.y) continue; // off screen (or no sample centre inside)
    walkSmall(a, b, d, lo, hi, vec2(0.0), uvec2(1), keepAll, mirrored, f,
              sampleTarget(v, t, eye, fade, false, c, inst, m, f));
  }
}
#else
// The cluster's triangles (vertices already in shared memory), one per thread per round.
void rasterCluster(uint v, GpuCluster c, GpuClusterInstance inst, ClusterFrame f, float fade, bool masked) {
  bool keepAll = (f.flags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 || (inst.flags & MIRAGE_INSTANCE_DOUBLE_SIDED) != 0;
  bool mirrored = (inst.flags & MIRAGE_INSTANCE_MIRRORED) != 0;
  GpuMaterial m;
  if (masked) m = instanceMaterial(inst);
  // Stereo: this thread's eye (sampleTarget: where its samples land, the frame its alpha test
  // sees). Written through kEyes so that the mono kernels fold the eye to 0 and carry no stereo code.
  const uint lanes = gl_WorkGroupSize.x / kEyes;
  uint eye = kEyes == 2 ? gl_LocalInvocationIndex / lanes : 0;
  uint lane = kEyes == 2 ? gl_LocalInvocationIndex % lanes : gl_LocalInvocationIndex;
  vec4 eyeDx = vec4(eye == 0 ? 0.0 : f.stereoClipDx, 0.0, 0.0, 0.0);
  for (uint t = lane; t < c.triangleCount; t += lanes) {
    uvec3 i = triangleCorners(c, t);
    SampleTarget target = sampleTarget(v, t, eye, fade, masked, c, inst, m, f);
    vec4 q[3] = vec4[3](clipPos[i.x], clipPos[i.y], clipPos[i.z]);
    float d[3] = float[3](nearDistance(q[0]), nearDistance(q[1]), nearDistance(q[2]));
    // The triangle, or its part beyond the near plane as a fan of one or two triangles p0 p1 p2
    // and p0 p2 p3 (near-clipped ones are never queued).
    vec3 p0, p1, p2, p3;
    eyeScreen(i, eye, p0, p1, p2);
    uint fan = 1, queueEntry = t | (eye << MIRAGE_CLUSTER_TRIANGLE_BITS);
    if (d[0] < 0.0 || d[1] < 0.0 || d[2] < 0.0) {
      if (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0) continue; // entirely in front of the near plane
      // Sutherland-Hodgman against the near plane: keep inside corners, add the crossing point of
      // each edge that crosses. One or two corners inside give a triangle or a quad, with the
      // original winding (w > 0 everywhere), so facing is decided per fan triangle as usual.
      vec4 clipped[4];
      uint n = 0;
      for (uint k = 0; k < 3; ++k) {
        uint k1 = k == 2 ? 0 : k + 1;
        if (d[k] >= 0.0) clipped[n++] = q[k];
        if ((d[k] >= 0.0) != (d[k1] >= 0.0)) clipped[n++] = mix(q[k], q[k1], d[k] / (d[k] - d[k1]));
      }
      if (eye == 0) atomicAdd(CounterRef(push.counterAddress).counters.trianglesNearClipped, 1);
      p0 = toScreen(clipped[0] + eyeDx, f.camera.viewport);
      p1 = toScreen(clipped[1] + eyeDx, f.camera.viewport);
      p2 = toScreen(clipped[2] + eyeDx, f.camera.viewport);
      if (n == 4) p3 = toScreen(clipped[3] + eyeDx, f.camera.viewport);
      fan = n - 2;
      queueEntry = ~0u;
    }
    // One call site (the walks are inlined): the fan's second triangle is the loop's second turn.
    [[dont_unroll]] for (uint k = 0; k < fan; ++k)
        rasterTriangle(p0, k == 0 ? p1 : p2, k == 0 ? p2 : p3, keepAll, mirrored, f, target, queueEntry);
  }
  barrier(); // the queue is complete (every thread left the loop above)
  // The queued triangles' tiles (never near-clipped), one per thread in turn.
  uint entries = uint(queuedCounts >> 32), tiles = uint(queuedCounts);
  for (uint item = gl_LocalInvocationIndex; item < tiles; item += gl_WorkGroupSize.x) {
    uint first = 0, last = entries - 1; // the last entry whose first tile is <= item
    while (first < last) {
      uint mid = (first + last + 1) / 2;
      if (queuedFirstTile[mid] <= item)
        first = mid;
      else
        last = mid - 1;
    }
    uint entry = queuedTriangles[first] & ~MIRAGE_RASTER_QUEUE_LATTICE, tile = item - queuedFirstTile[first];
    uint t = entry & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
    uint tileEye = kEyes == 2 ? entry >> MIRAGE_CLUSTER_TRIANGLE_BITS : 0; // the tile's eye, not the thread's
    vec3 s0, s1, s2;
    eyeScreen(triangleCorners(c, t), tileEye, s0, s1, s2);
    SampleTarget target = sampleTarget(v, t, tileEye, fade, masked, c, inst, m, f);
    vec2 lo, hi;
    sampleBox(s0, s1, s2, f.camera.viewport, lo, hi);
#ifdef MIRAGE_RASTER_MARK
    vec2 tileLo, tileHi;
    if (markQueuedTile(s0, s1, s2, lo, hi, tile, f, tileLo, tileHi))
      walkQueued(s0, s1, s2, tileLo, tileHi, vec2(0.0), uvec2(1), keepAll, mirrored, f, target);
#else
    uint tilesX = uint(ceil((hi.x - lo.x + 1.0) / MIRAGE_RASTER_TILE));
    vec2 tileLo = lo + vec2(tile % tilesX, tile / tilesX) * MIRAGE_RASTER_TILE;
    walkQueued(s0, s1, s2, tileLo, min(tileLo + (MIRAGE_RASTER_TILE - 1.0), hi), vec2(0.0), uvec2(1), keepAll, mirrored,
               f, target);
#endif
  }
  // The largest boxes, each over its eye's threads as a lattice (neighbouring threads write
  // neighbouring pixels: the atomics of a warp share cache lines).
  vec2 lattice = vec2(lane % MIRAGE_RASTER_LATTICE, lane / MIRAGE_RASTER_LATTICE);
  uvec2 latticeStride = uvec2(MIRAGE_RASTER_LATTICE, lanes / MIRAGE_RASTER_LATTICE);
  for (uint k = 0; k < entries; ++k) {
    uint entry = queuedTriangles[k];
    if ((entry & MIRAGE_RASTER_QUEUE_LATTICE) == 0) continue;
    entry &= ~MIRAGE_RASTER_QUEUE_LATTICE;
    if (entry >> MIRAGE_CLUSTER_TRIANGLE_BITS != eye) continue; // uniform per eye's half (whole warps)
    uint t = entry & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
    vec3 s0, s1, s2;
    eyeScreen(triangleCorners(c, t), eye, s0, s1, s2);
    SampleTarget target = sampleTarget(v, t, eye, fade, masked, c, inst, m, f);
    vec2 lo, hi;
    sampleBox(s0, s1, s2, f.camera.viewport, lo, hi);
    walkQueued(s0, s1, s2, lo, hi, lattice, latticeStride, keepAll, mirrored, f, target);
  }
}
#endif // MIRAGE_RASTER_LEAN

void main() {
  uint v = rasterEntry(gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x);
  if (v == ~0u) return; // uniform over the workgroup
  ClusterFrame f = FrameRef(push.frameAddress).frame;
#ifdef MIRAGE_RASTER_BLEND
  if (!oitBeginBlendPass(f)) return; // uniform: a fixed-slot frame's second rasterization with nothing to redo
#endif
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  // Masked clusters are drawn by their own pipeline (cluster_raster_mask.comp) over the same list:
  // the opaque kernel is today's loop with no alpha code (no added registers), and each kernel
  // skips the other's clusters at this uniform test. Blended clusters are never alpha-tested
  // (their alpha blends in the composite).
  bool masked = (inst.flags & MIRAGE_INSTANCE_ALPHA_MASK) != 0;
#if defined(MIRAGE_RASTER_LEAN)
  // Never masked (leanRasterCluster): nothing to skip.
#elif defined(MIRAGE_RASTER_MASK)
  if (!masked) return;
#elif !defined(MIRAGE_RASTER_BLEND)
  if (masked) return;
#endif
  visRowPixels = uint(f.camera.viewport.x) * kEyes;
#ifndef MIRAGE_RASTER_LEAN
  if (gl_LocalInvocationIndex == 0) queuedCounts = 0; // published by the barrier after the vertices
#endif
  mat4 mvp = f.camera.viewProj * inst.model;
  for (uint i = gl_LocalInvocationIndex; i < c.vertexCount; i += gl_WorkGroupSize.x) {
    uint id = UintRef(push.clusterVertexAddress).data[c.vertexOffset + i];
    vec4 clip = mvp * vec4(VertexRef(push.vertexAddress).vertices[id].position, 1.0);
#ifndef MIRAGE_RASTER_LEAN
    clipPos[i] = clip;
#endif
    screen[i] = toScreen(clip, f.camera.viewport);
    if (kEyes == 2) screenRightX[i] = toScreen(clip + vec4(f.stereoClipDx, 0.0, 0.0, 0.0), f.camera.viewport).x;
  }
  barrier();
#if defined(MIRAGE_RASTER_LEAN)
  rasterClusterLean(v, c, inst, f, instanceFade(vc.instance));
#elif defined(MIRAGE_RASTER_MASK)
  rasterCluster(v, c, inst, f, instanceFade(vc.instance), true);
#else
  rasterCluster(v, c, inst, f, instanceFade(vc.instance), false);
#endif
}
