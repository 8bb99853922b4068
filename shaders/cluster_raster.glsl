// Body of the compute software rasterizers (cluster_raster.comp: opaque clusters, and
// cluster_raster_mask.comp, MIRAGE_RASTER_MASK: masked ones, into the 64-bit visibility buffer;
// cluster_raster_blend.comp, MIRAGE_RASTER_BLEND: blended clusters into the transparency lists).
// One workgroup per visible cluster; each thread walks the pixel bounding box of its triangles and
// keeps the nearest sample with a 64-bit atomicMax of
// (reverse-Z depth bits << 32 | ((visible index + 1) << 7 | triangle)): larger depth is nearer and
// positive float bits order like the floats. Vertices snap to 1/256 pixel and ties follow the
// top-left rule, as fixed-function hardware does, so the ids match the other backends.
// Triangles crossing the near plane are clipped against it in clip space (at most a quad, drawn as
// a two-triangle fan), so a camera inside or next to the geometry draws what the hardware draws.
// Stereo (kEyes = 2, the left eye's frame): each vertex is transformed once; the right eye's clip
// position is the left one's with x + stereoClipDx (y, z, w are the same), so only its screen x is
// kept too, and every triangle is drawn into both halves of the 2W-wide buffer (an eye whose
// bounding box misses its half loops over nothing). The workgroup doubles: its first
// MIRAGE_CLUSTER_WORKGROUP threads draw the left eye, the others the right, so a thread walks as
// many triangles as in mono (the pass is bound by that serial walk, not by the vertex transform).
// Near-plane clipping is per eye for free: the near distance w - z is the same in both eyes.
#extension GL_EXT_nonuniform_qualifier : require
#include "cluster_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];

#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_alpha.glsl"

// Specialization: eyes drawn (1, or 2 for stereo), and the workgroup size, kEyes * MIRAGE_CLUSTER_WORKGROUP.
layout(constant_id = 0) const uint kEyes = 1;
layout(local_size_x_id = 1) in;

shared vec4 clipPos[MIRAGE_CLUSTER_MAX_VERTICES]; // clip space (only read for near-crossing triangles)
shared vec3 screen[MIRAGE_CLUSTER_MAX_VERTICES];  // pixels x, y; depth z/w
// Stereo: the right eye's pixel x. One element in the mono kernels, whose shared memory (and so
// workgroups per SM: the raster is latency-bound) stays as it was.
shared float screenRightX[kEyes == 2 ? MIRAGE_CLUSTER_MAX_VERTICES : 1];

uint visRowPixels; // pixels per row of the 64-bit buffer: the viewport's width, both eyes' in stereo

float edge(vec2 a, vec2 b, vec2 p) { return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x); }
// An edge's function evaluated from its endpoints in one canonical order (by y, then x) and
// negated when (a, b) is the other order: two triangles sharing an edge then compute bit-identical
// values of opposite sign at every sample (the float products round, but identically), so the
// top-left rule gives each shared-edge sample to exactly one of them (no double blends, no cracks).
struct Edge {
  vec2 u, v;
  float sign;
};
Edge canonicalEdge(vec2 a, vec2 b) {
  bool swap = a.y > b.y || (a.y == b.y && a.x > b.x);
  return Edge(swap ? b : a, swap ? a : b, swap ? -1.0 : 1.0);
}
float edgeAt(Edge e, vec2 p) { return e.sign * edge(e.u, e.v, p); }

bool topLeft(vec2 a, vec2 b) {
  vec2 d = b - a;
  return (d.y == 0.0 && d.x > 0.0) || d.y < 0.0;
}

// Signed distance to the near plane in clip space: reverse-Z puts the near plane at z = w, so
// w - z >= 0 is in front of it (and w >= znear > 0 there, so the divide below is safe).
float nearDistance(vec4 clip) { return clip.w - clip.z; }

vec3 toScreen(vec4 clip, vec2 viewport) {
  vec3 ndc = clip.xyz / clip.w;
  vec2 px = (ndc.xy * 0.5 + 0.5) * viewport;
  return vec3(round(px * 256.0) / 256.0, ndc.z);
}

#ifdef MIRAGE_RASTER_BLEND
#include "cluster_oit.glsl"
layout(set = 0, binding = 3) uniform sampler2D opaqueDepthImage; // image backends' depth

// Nearest opaque depth of pixel (x, y): the 64-bit buffer's high word (compute, hybrid) or the
// hardware depth (mesh, indirect); 0 (far) where nothing opaque was drawn.
float opaqueDepth(ClusterFrame f, uint x, uint y) {
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) == 0) return texelFetch(opaqueDepthImage, ivec2(x, y), 0).r;
  return bufferOpaqueDepth(f, x, y);
}

// A blended fragment in front of the opaque surface: onto its pixel's list (cluster_oit.glsl).
void writeSample(ClusterFrame f, uint x, uint y, float z, uint id) {
  if (z > opaqueDepth(f, x, y)) oitAppend(f, x, y, z, id);
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
// while its neighbours cover a few pixels each (coarse cuts, larger tau, foveation). They queue
// here (triangle index | eye << 7) and each eye's threads walk their eye's queued boxes after the
// per-thread pass, every thread one pixel of each 8 x 8 block. The same loop serves both walks, so
// the kernel needs no more registers than the per-thread walk.
#define MIRAGE_RASTER_SHARED_PIXELS 64
#define MIRAGE_RASTER_LATTICE 8 // MIRAGE_RASTER_LATTICE^2 == MIRAGE_CLUSTER_WORKGROUP
shared uint queuedTriangles[MIRAGE_CLUSTER_MAX_TRIANGLES * kEyes];
shared uint queuedCount;

// One screen-space triangle (snapped vertices) into the 64-bit visibility buffer (or the
// transparency lists): the pixels lattice + k * stride of its box. A large box goes to the
// workgroup's queue as `queueEntry` instead (~0u: never). `masked`: a constant per kernel, so the
// opaque one carries no alpha code; masked pixels pass maskKeeps on `tri` (the unclipped triangle)
// first, seen from the frame at `eyeFrame`. Samples land `eyeX` pixels right of the eye's own
// pixel (stereo's right half).
void rasterTriangle(vec3 a, vec3 p1, vec3 p2, uint id, bool keepAll, bool mirrored, ClusterFrame f, float fade,
                    bool masked, ClusterTriangle tri, GpuMaterial m, uint64_t eyeFrame, uint eyeX, vec2 lattice,
                    float stride, uint queueEntry) {
  vec2 viewport = f.camera.viewport;
  float area = edge(a.xy, p1.xy, p2.xy);
  if (area == 0.0) return;
  // Vulkan: with y down, a counter-clockwise (front) triangle has a negative edge area here.
  bool front = area < 0.0;
  if (!keepAll && front == mirrored) return;
  if (area < 0.0) { // orient so inside is positive for all three edges
    vec3 tmp = p1;
    p1 = p2;
    p2 = tmp;
    area = -area;
  }
  vec2 lo = max(floor(min(a.xy, min(p1.xy, p2.xy)) - 0.5), vec2(0.0));
  vec2 hi = min(ceil(max(a.xy, max(p1.xy, p2.xy)) - 0.5), viewport - 1.0);
  vec2 box = hi - lo + 1.0;
  if (queueEntry != ~0u && box.x * box.y > float(MIRAGE_RASTER_SHARED_PIXELS)) {
    queuedTriangles[atomicAdd(queuedCount, 1u)] = queueEntry;
    return;
  }
  bool tl0 = topLeft(p1.xy, p2.xy), tl1 = topLeft(p2.xy, a.xy), tl2 = topLeft(a.xy, p1.xy);
  Edge e0 = canonicalEdge(p1.xy, p2.xy), e1 = canonicalEdge(p2.xy, a.xy), e2 = canonicalEdge(a.xy, p1.xy);
  for (float y = lo.y + lattice.y; y <= hi.y; y += stride) {
    for (float x = lo.x + lattice.x; x <= hi.x; x += stride) {
      vec2 s = vec2(x + 0.5, y + 0.5);
      float w0 = edgeAt(e0, s), w1 = edgeAt(e1, s), w2 = edgeAt(e2, s);
      if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
      if ((w0 == 0.0 && !tl0) || (w1 == 0.0 && !tl1) || (w2 == 0.0 && !tl2)) continue;
      float z = (w0 * a.z + w1 * p1.z + w2 * p2.z) / area;
      if (z < 0.0) continue; // beyond the far plane
      if (!meshKeepsPixel(fade, uvec2(x, y))) continue; // the surfels' pixel in the blend band
      if (masked && !maskKeeps(FrameRef(eyeFrame).frame, m, tri, s)) continue; // alpha below the cutoff: a hole
      writeSample(f, uint(x) + eyeX, uint(y), z, id);
    }
  }
}

// The cluster's triangles (vertices already in shared memory), one per thread per round.
void rasterCluster(uint v, GpuCluster c, GpuClusterInstance inst, ClusterFrame f, float fade, bool masked) {
  bool keepAll = (f.flags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 || (inst.flags & MIRAGE_INSTANCE_DOUBLE_SIDED) != 0;
  bool mirrored = (inst.flags & MIRAGE_INSTANCE_MIRRORED) != 0;
  GpuMaterial m;
  if (masked) m = instanceMaterial(inst);
  // Stereo: this thread's eye, where its samples land, and the frame its alpha test sees. Written
  // through kEyes so that the mono kernels fold the eye to 0 and carry no stereo code.
  uint eye = kEyes == 2 ? gl_LocalInvocationIndex / MIRAGE_CLUSTER_WORKGROUP : 0;
  uint lane = kEyes == 2 ? gl_LocalInvocationIndex % MIRAGE_CLUSTER_WORKGROUP : gl_LocalInvocationIndex;
  uint eyeX = eye * uint(f.camera.viewport.x);
  uint64_t eyeFrame = push.frameAddress + eye * MIRAGE_CLUSTER_FRAME_STRIDE;
  vec4 eyeDx = vec4(eye == 0 ? 0.0 : f.stereoClipDx, 0.0, 0.0, 0.0);
  for (uint t = lane; t < c.triangleCount; t += MIRAGE_CLUSTER_WORKGROUP) {
    uint b = (c.triangleOffset + t) * 3u;
    uint i0 = localIndex(b), i1 = localIndex(b + 1), i2 = localIndex(b + 2);
    uint id = ((v + 1) << MIRAGE_CLUSTER_TRIANGLE_BITS) | t;
    ClusterTriangle tri;
    if (masked) tri = fetchTriangle(c, inst, t);
    vec4 q[3] = vec4[3](clipPos[i0], clipPos[i1], clipPos[i2]);
    float d[3] = float[3](nearDistance(q[0]), nearDistance(q[1]), nearDistance(q[2]));
    if (d[0] >= 0.0 && d[1] >= 0.0 && d[2] >= 0.0) {
      vec3 s0 = screen[i0], s1 = screen[i1], s2 = screen[i2];
      if (eye == 1) {
        s0.x = screenRightX[i0];
        s1.x = screenRightX[i1];
        s2.x = screenRightX[i2];
      }
      rasterTriangle(s0, s1, s2, id, keepAll, mirrored, f, fade, masked, tri, m, eyeFrame, eyeX, vec2(0.0), 1.0,
                     t | (eye << MIRAGE_CLUSTER_TRIANGLE_BITS));
      continue;
    }
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
    vec3 poly[4];
    for (uint k = 0; k < n; ++k) poly[k] = toScreen(clipped[k] + eyeDx, f.camera.viewport);
    rasterTriangle(poly[0], poly[1], poly[2], id, keepAll, mirrored, f, fade, masked, tri, m, eyeFrame, eyeX, vec2(0.0),
                   1.0, ~0u);
    if (n == 4)
      rasterTriangle(poly[0], poly[2], poly[3], id, keepAll, mirrored, f, fade, masked, tri, m, eyeFrame, eyeX,
                     vec2(0.0), 1.0, ~0u);
  }
  barrier(); // the queue is complete (every thread left the loop above)
  // The queued triangles (never near-clipped), each box over its eye's threads as an 8 x 8 lattice.
  vec2 lattice = vec2(lane % MIRAGE_RASTER_LATTICE, lane / MIRAGE_RASTER_LATTICE);
  for (uint k = 0; k < queuedCount; ++k) {
    uint entry = queuedTriangles[k];
    if (entry >> MIRAGE_CLUSTER_TRIANGLE_BITS != eye) continue; // uniform per eye's half (whole warps)
    uint t = entry & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
    uint b = (c.triangleOffset + t) * 3u;
    uint i0 = localIndex(b), i1 = localIndex(b + 1), i2 = localIndex(b + 2);
    vec3 s0 = screen[i0], s1 = screen[i1], s2 = screen[i2];
    if (eye == 1) {
      s0.x = screenRightX[i0];
      s1.x = screenRightX[i1];
      s2.x = screenRightX[i2];
    }
    ClusterTriangle tri;
    if (masked) tri = fetchTriangle(c, inst, t);
    rasterTriangle(s0, s1, s2, ((v + 1) << MIRAGE_CLUSTER_TRIANGLE_BITS) | t, keepAll, mirrored, f, fade, masked, tri,
                   m, eyeFrame, eyeX, lattice, float(MIRAGE_RASTER_LATTICE), ~0u);
  }
}

void main() {
  uint v = rasterEntry(gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x);
  if (v == ~0u) return; // uniform over the workgroup
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  // Masked clusters are drawn by their own pipeline (cluster_raster_mask.comp) over the same list:
  // the opaque kernel is today's loop with no alpha code (no added registers), and each kernel
  // skips the other's clusters at this uniform test. Blended clusters are never alpha-tested
  // (their alpha blends in the composite).
  bool masked = (inst.flags & MIRAGE_INSTANCE_ALPHA_MASK) != 0;
#if defined(MIRAGE_RASTER_MASK)
  if (!masked) return;
#elif !defined(MIRAGE_RASTER_BLEND)
  if (masked) return;
#endif
  visRowPixels = uint(f.camera.viewport.x) * kEyes;
  if (gl_LocalInvocationIndex == 0) queuedCount = 0; // published by the barrier after the vertices
  mat4 mvp = f.camera.viewProj * inst.model;
  for (uint i = gl_LocalInvocationIndex; i < c.vertexCount; i += gl_WorkGroupSize.x) {
    uint id = UintRef(push.clusterVertexAddress).data[c.vertexOffset + i];
    vec4 clip = mvp * vec4(VertexRef(push.vertexAddress).vertices[id].position, 1.0);
    clipPos[i] = clip;
    screen[i] = toScreen(clip, f.camera.viewport);
    if (kEyes == 2) screenRightX[i] = toScreen(clip + vec4(f.stereoClipDx, 0.0, 0.0, 0.0), f.camera.viewport).x;
  }
  barrier();
#if defined(MIRAGE_RASTER_MASK)
  rasterCluster(v, c, inst, f, instanceFade(vc.instance), true);
#else
  rasterCluster(v, c, inst, f, instanceFade(vc.instance), false);
#endif
}
