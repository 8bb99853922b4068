// Shared declarations of the cluster-LOD shaders: every array through a buffer device address in
// ClusterPush (include/mirage/shaderio/cluster.h), and helpers to fetch a cluster's triangles.
#ifndef MIRAGE_CLUSTER_COMMON_GLSL
#define MIRAGE_CLUSTER_COMMON_GLSL
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/cluster.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer FrameRef { ClusterFrame frame; };
// Cluster records by record index (VisibleCluster::cluster): with residency push.clusterAddress names
// the page pool, whose units hold the records of their pages (GpuCluster).
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ClusterRef { GpuCluster clusters[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VertexRef { GpuClusterVertex vertices[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MeshRef { GpuClusterMesh meshes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer InstanceRef { GpuClusterInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MaterialRef { GpuMaterial materials[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer UintRef { uint data[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer VisibleRef { VisibleCluster visible[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer VisibleInstanceRef { VisibleInstance entries[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LevelRef { GpuClusterLevel levels[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer CounterRef { ClusterCounters counters; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer VisBufferRef { uint64_t pixels[]; };
// The global queue of large triangles (the blend rasters', and the atlas server's depth raster's).
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer BlendQueueRef { BlendQueueTriangle triangles[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer FloatRef { float data[]; };

layout(push_constant, scalar) uniform Push { ClusterPush push; };

#include "oit_list.glsl" // the transparency lists, shared with the forward renderer

// The frame of the eye being drawn (docs/render.md, "Stereo"): stereo by multiview draws both eyes
// with the left eye's frame pushed, the right eye's following it; the shaders of those draws define
// MIRAGE_VIEW_INDEX as gl_ViewIndex (0 in every other rendering). Elsewhere the pushed frame is the eye's.
#ifndef MIRAGE_VIEW_INDEX
#define MIRAGE_VIEW_INDEX 0
#endif
uint64_t eyeFrameAddress() { return push.frameAddress + uint64_t(MIRAGE_VIEW_INDEX) * MIRAGE_CLUSTER_FRAME_STRIDE; }

// Cluster PVS of the camera's cell (MIRAGE_FRAME_PVS): whether mesh-local cluster `meshLocal` of
// instance `instance` may be visible from the cell. Instances outside it never reach selection.
bool pvsClusterVisible(ClusterFrame f, uint instance, uint meshLocal) {
  if ((f.flags & MIRAGE_FRAME_PVS) == 0) return true;
  uint base = UintRef(f.pvsInstanceAddress).data[instance];
  if (base == MIRAGE_PVS_INSTANCE_CULLED) return false;
  uint bit = base + meshLocal;
  return (UintRef(f.pvsClusterAddress).data[bit >> 5] & (1u << (bit & 31u))) != 0;
}

// Local 8-bit index number `i` of the global index array (packed four per word).
// Pixels per row of the per-pixel buffers (64-bit visibility, transparency heads): the viewport's
// width, or both eyes' side by side in stereo frames (MIRAGE_FRAME_STEREO).
uint targetRowPixels(ClusterFrame f) {
  return uint(f.camera.viewport.x) * ((f.flags & MIRAGE_FRAME_STEREO) != 0 ? 2u : 1u);
}

uint localIndex(uint i) {
  uint word = UintRef(push.indexAddress).data[i >> 2];
  return (word >> ((i & 3u) * 8u)) & 0xffu;
}

// Attribute-vertex id of corner k of triangle t of cluster c.
uint triangleVertex(GpuCluster c, uint t, uint k) {
  uint local = localIndex((c.triangleOffset + t) * 3u + k);
  return UintRef(push.clusterVertexAddress).data[c.vertexOffset + local];
}

// Entry `i` of a visible-cluster list: the up list from the front, the down list from the back
// (of the blend list with MIRAGE_BLEND_LISTS: the blend rasters).
uint listEntry(uint list, uint i) {
#ifdef MIRAGE_BLEND_LISTS
  uint capacity = FrameRef(push.frameAddress).frame.blendCapacity;
#else
  uint capacity = FrameRef(push.frameAddress).frame.visibleCapacity;
#endif
  return list == MIRAGE_LIST_UP ? i : capacity - 1u - i;
}

// The raster pass's share of its list (push.rasterList = pass * 2 + list): entries
// [first, first + count).
uvec2 rasterRange() {
  ClusterListArgs a = CounterRef(push.counterAddress).counters.lists[push.rasterList >> 1][push.rasterList & 1u];
  return uvec2(a.first, a.count);
}

// Visible-list entry of the raster pass's cluster number `v`, or ~0u past its end.
uint rasterEntry(uint v) {
  uvec2 range = rasterRange();
  return v < range.y ? listEntry(push.rasterList & 1u, range.x + v) : ~0u;
}

// Appends to a list; false (and counted) past the shared capacity: one ticket counter covers both
// lists, so the up and down lists never meet.
bool appendVisible(uint list, VisibleCluster vc) {
  CounterRef counters = CounterRef(push.counterAddress);
  if (atomicAdd(counters.counters.allocated, 1) >= FrameRef(push.frameAddress).frame.visibleCapacity) {
    atomicAdd(counters.counters.clustersOverflow, 1);
    return false;
  }
  uint slot = atomicAdd(counters.counters.listEnd[list], 1);
  VisibleRef(push.visibleAddress).visible[listEntry(list, slot)] = vc;
  return true;
}

// Whether a fragment of visible cluster `v` survives facing rules: single-sided materials drop back
// faces (mirrored instances swap front and back, as glTF asks); the crack-test mode keeps all.
bool keepFacing(uint v, bool frontFacing) {
  uint frameFlags = FrameRef(push.frameAddress).frame.flags;
  uint flags = InstanceRef(push.instanceAddress).instances[VisibleRef(push.visibleAddress).visible[v].instance].flags;
  if ((frameFlags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 || (flags & MIRAGE_INSTANCE_DOUBLE_SIDED) != 0) return true;
  return frontFacing != ((flags & MIRAGE_INSTANCE_MIRRORED) != 0);
}

// Sphere against the frustum planes of the camera moved by `shift` (conservative: inside or
// intersecting). A translated frustum keeps its normals: plane w becomes w - dot(n, shift).
bool sphereInFrustum(ClusterFrame f, vec4 s, vec3 shift) {
  for (int i = 0; i < 5; ++i)
    if (dot(f.camera.planes[i].xyz, s.xyz - shift) + f.camera.planes[i].w < -s.w) return false;
  return true;
}

// Sphere against the view: in stereo, the union of both eyes' frusta (ClusterFrame::stereoHalf).
bool sphereVisible(vec4 s) {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  vec3 h = f.stereoHalf.xyz;
  if (h == vec3(0.0)) return sphereInFrustum(f, s, vec3(0.0));
  return sphereInFrustum(f, s, -h) || sphereInFrustum(f, s, h);
}

// The eye nearest to `p`: the camera in mono, the nearest point of the segment between the two
// eyes in stereo (LOD error from there is never below either eye's: conservative for both).
vec3 nearestEye(ClusterFrame f, vec3 p) {
  vec3 h = f.stereoHalf.xyz;
  float hh = dot(h, h);
  if (hh == 0.0) return f.camera.eye.xyz;
  float t = clamp(dot(p - f.camera.eye.xyz, h) / hh, -1.0, 1.0);
  return f.camera.eye.xyz + t * h;
}

// Hybrid raster: true when the cluster goes to the hardware list: its estimated triangle edge
// (projected sphere diameter / sqrt(triangles)) reaches the threshold, or its sphere reaches the
// near plane (big on screen and clipped: fixed-function clipping is cheaper).
bool hardwareCluster(vec4 worldSphere, uint triangles, ClusterFrame f) {
  float d = length(worldSphere.xyz - nearestEye(f, worldSphere.xyz)) - worldSphere.w;
  if (d <= f.camera.znear) return true;
  float diameter = 2.0 * worldSphere.w / d * f.camera.pixelScale;
  return diameter >= f.hybridThreshold * sqrt(float(max(triangles, 1u)));
}

// The compute raster's walks (cluster_raster.glsl): a triangle whose sample box exceeds
// MIRAGE_RASTER_SHARED_PIXELS goes to its workgroup's queue, one spanning MIRAGE_RASTER_SMALL_EXTENT
// or more takes a 64-bit walk (cluster_raster_edges.glsl); the lean test below keeps its clusters
// under the latter.
#define MIRAGE_RASTER_SHARED_PIXELS 128
#define MIRAGE_RASTER_SMALL_EXTENT 63.0 // pixels: 32-bit edge values stay below 2^30
// The lean kernel walks every triangle on its own thread whatever its box (no queue): correct for
// any extent under MIRAGE_RASTER_SMALL_EXTENT, and fast while no thread walks much longer than its
// warp's others. Up to 16 pixels across (boxes of at most 19 x 19 samples) keeps that, and takes
// most clusters of a far view (2500 blobs at 1080p: 618 of 3173 with boxes held to the queue's
// 128 samples).
#define MIRAGE_RASTER_LEAN_EXTENT 16.0

// Lean raster (MIRAGE_FRAME_LEAN_RASTER; docs/render.md, "Lean raster"): true when every triangle
// of cluster c drawn by `inst` can be walked by its own thread's 32-bit walk: the cluster is not
// alpha-masked, its bounding sphere lies wholly beyond the near plane (no clipping), and a bound on
// any triangle's screen extent stays under MIRAGE_RASTER_LEAN_EXTENT (< MIRAGE_RASTER_SMALL_EXTENT).
// The bound, in object space (exact for any affine model matrix): with clip rows X, W of
// viewProj * model, two points p, q of the sphere with d = q - p project to ndc x that differ by
// (X.xyz - n W.xyz) . d / W_q, n = X_p / W_p; so by at most |X.xyz - n W.xyz| maxEdge / Wmin, Wmin
// the sphere's smallest W, the norm largest at one end of n's range over the sphere (it is
// convex in n). y alike.
// Stereo draws from the left eye's frame; the right eye's clip x is shifted by stereoClipDx.
float leanNdcSpan(vec4 row, vec4 rw, vec3 o, float r, float wmin, float wmax, float shift) {
  float c = dot(row.xyz, o) + row.w, reach = length(row.xyz) * r;
  float lo = c - reach + min(shift, 0.0), hi = c + reach + max(shift, 0.0);
  float nlo = min(lo / wmin, lo / wmax), nhi = max(hi / wmin, hi / wmax); // wmin > 0
  return max(length(row.xyz - nlo * rw.xyz), length(row.xyz - nhi * rw.xyz)) / wmin;
}
bool leanRasterCluster(GpuCluster c, GpuClusterInstance inst, ClusterFrame f) {
  if ((inst.flags & MIRAGE_INSTANCE_ALPHA_MASK) != 0) return false; // the mask kernel's
  bool stereo = (f.flags & MIRAGE_FRAME_STEREO) != 0;
  uint64_t eyeFrame = push.frameAddress + (stereo ? MIRAGE_CLUSTER_FRAME_STRIDE : 0);
  mat4 vp = FrameRef(eyeFrame).frame.camera.viewProj;
  vec2 viewport = FrameRef(eyeFrame).frame.camera.viewport;
  float clipDx = stereo ? FrameRef(eyeFrame).frame.stereoClipDx : 0.0;
  // Rows x, y, z, w of viewProj * model.
  vec4 rx = vec4(vp[0][0], vp[1][0], vp[2][0], vp[3][0]) * inst.model;
  vec4 ry = vec4(vp[0][1], vp[1][1], vp[2][1], vp[3][1]) * inst.model;
  vec4 rz = vec4(vp[0][2], vp[1][2], vp[2][2], vp[3][2]) * inst.model;
  vec4 rw = vec4(vp[0][3], vp[1][3], vp[2][3], vp[3][3]) * inst.model;
  vec3 o = c.boundsSphere.xyz;
  float r = c.boundsSphere.w * 1.001; // the sphere's float rounding
  float wc = dot(rw.xyz, o) + rw.w, wr = length(rw.xyz) * r;
  // The near distance w - z (cluster_raster.glsl's nearDistance) is linear: positive over the
  // whole sphere, with a margin far above the raster's float rounding of w - z.
  vec4 rn = rw - rz;
  if (!(dot(rn.xyz, o) + rn.w - length(rn.xyz) * r > 1e-3 * (abs(wc) + wr))) return false;
  float wmin = wc - wr, wmax = wc + wr;
  if (!(wmin > 0.0)) return false;
  vec2 span = vec2(leanNdcSpan(rx, rw, o, r, wmin, wmax, clipDx), leanNdcSpan(ry, rw, o, r, wmin, wmax, 0.0));
  vec2 extent = 0.5 * viewport * span * c.maxEdge;
  extent = extent * 1.001 + 1.0 / 128.0; // float rounding; snapping moves each corner up to 1/512 px
  return max(extent.x, extent.y) < MIRAGE_RASTER_LEAN_EXTENT;
}

// A cluster to draw in the current pass (instance `inst`, world sphere `worldSphere`): into the
// hardware list (hybrid, large triangles), the lean list (compute, leanRasterCluster) or the up
// list, counted. False when the lists are full.
bool emitCluster(VisibleCluster vc, vec4 worldSphere, GpuCluster c, GpuClusterInstance inst, ClusterFrame f) {
  bool hardware = (f.flags & MIRAGE_FRAME_HYBRID) != 0 && hardwareCluster(worldSphere, c.triangleCount, f);
  bool lean = (f.flags & MIRAGE_FRAME_LEAN_RASTER) != 0 && leanRasterCluster(c, inst, f);
  if (!appendVisible(hardware || lean ? MIRAGE_LIST_DOWN : MIRAGE_LIST_UP, vc)) return false;
  CounterRef counters = CounterRef(push.counterAddress);
  atomicAdd(counters.counters.trianglesSelected, c.triangleCount);
  if (hardware) atomicAdd(counters.counters.clustersHardware, 1);
  return true;
}

// World-space culling sphere of cluster `c` drawn by instance `inst`.
vec4 worldSphere(GpuCluster c, GpuClusterInstance inst) {
  return vec4((inst.model * vec4(c.boundsSphere.xyz, 1.0)).xyz, c.boundsSphere.w * inst.maxScale);
}

// Hierarchical depth test of a world-space sphere (conservative: true = may be visible). The
// sphere's bounding cube is projected to a pixel rectangle; the HZB level (>= 1) where the
// rectangle spans at most three texels per axis gives the farthest depth drawn over it; the sphere is hidden when
// its nearest point is farther still (reverse-Z: smaller). Spheres reaching the near plane are
// visible.
// Stereo: the HZB spans both eyes side by side (2W wide; a texel straddling the seam holds the
// farther of both, which only culls less); `f` is one eye's frame, its rectangle kept in its half.
bool hzbVisibleIn(ClusterFrame f, vec4 s) {
  vec4 row3 = vec4(f.camera.viewProj[0][3], f.camera.viewProj[1][3], f.camera.viewProj[2][3], f.camera.viewProj[3][3]);
  float w = dot(row3.xyz, s.xyz) + row3.w; // view depth of the centre (row 3 has a unit forward axis)
  if (w - s.w * 1.7321 <= f.camera.znear) return true;
  vec2 lo = vec2(1e30), hi = vec2(-1e30);
  for (int k = 0; k < 8; ++k) {
    vec3 corner = s.xyz + s.w * vec3((k & 1) != 0 ? 1.0 : -1.0, (k & 2) != 0 ? 1.0 : -1.0, (k & 4) != 0 ? 1.0 : -1.0);
    vec4 clip = f.camera.viewProj * vec4(corner, 1.0);
    vec2 px = (clip.xy / clip.w * 0.5 + 0.5) * f.camera.viewport;
    lo = min(lo, px);
    hi = max(hi, px);
  }
  vec4 nearest = f.camera.viewProj * vec4(s.xyz - s.w * row3.xyz, 1.0);
  float nearestDepth = nearest.z / nearest.w;
  ivec2 p0 = clamp(ivec2(floor(lo)), ivec2(0), ivec2(f.camera.viewport) - 1) + ivec2(f.targetOffsetX, 0);
  ivec2 p1 = clamp(ivec2(floor(hi)), ivec2(0), ivec2(f.camera.viewport) - 1) + ivec2(f.targetOffsetX, 0);
  int extent = max(p1.x - p0.x, p1.y - p0.y) + 1;
  // 2^level >= extent / 2; level 0 (full resolution) is not stored.
  int level = clamp(findMSB(max(extent - 1, 1)), 1, int(f.hzbLevels) - 1);
  ivec2 t0 = p0 >> level, t1 = p1 >> level;
  int levelWidth = (int(targetRowPixels(f)) + (1 << level) - 1) >> level;
  FloatRef hzb = FloatRef(f.hzbAddress);
  float farthest = 1.0;
  for (int y = t0.y; y <= t1.y; ++y)
    for (int x = t0.x; x <= t1.x; ++x) farthest = min(farthest, hzb.data[f.hzbOffset[level] + y * levelWidth + x]);
  return nearestDepth >= farthest;
}

// The selection and occlusion passes' test (their frame is the selection frame): in stereo a sphere
// is hidden only when hidden from both eyes (the eye frames follow the selection frame).
bool hzbVisible(vec4 s) {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if ((f.flags & MIRAGE_FRAME_STEREO) == 0) return hzbVisibleIn(f, s);
  return hzbVisibleIn(FrameRef(push.frameAddress + MIRAGE_CLUSTER_FRAME_STRIDE).frame, s) ||
         hzbVisibleIn(FrameRef(push.frameAddress + 2 * MIRAGE_CLUSTER_FRAME_STRIDE).frame, s);
}

// Visibility-history bits: (instance, cluster) pairs at inst.historyOffset + mesh-local cluster,
// then one bit per instance at frame.instanceHistoryBase + instance.
bool historyBitAt(uint bit) {
  return (UintRef(FrameRef(push.frameAddress).frame.historyAddress).data[bit >> 5] & (1u << (bit & 31u))) != 0;
}
bool historyBit(GpuClusterInstance inst, uint local) { return historyBitAt(inst.historyOffset + local); }
// Sets the bit; true when this call set it (it was clear).
bool setHistoryBitAt(uint bit) {
  UintRef history = UintRef(FrameRef(push.frameAddress).frame.historyAddress);
  if ((history.data[bit >> 5] & (1u << (bit & 31u))) != 0) return false; // most pixels: no atomic
  return (atomicOr(history.data[bit >> 5], 1u << (bit & 31u)) & (1u << (bit & 31u))) == 0;
}

// Overdraw debug view: one more sample covering pixel p of the target (both eyes side by side in
// stereo), counted before the depth test.
void countOverdraw(ClusterFrame f, uvec2 p) {
  if ((f.flags & MIRAGE_FRAME_OVERDRAW) != 0)
    atomicAdd(UintRef(f.overdrawAddress).data[p.y * targetRowPixels(f) + p.x], 1u);
}

#include "cluster_fade.glsl"
#endif // MIRAGE_CLUSTER_COMMON_GLSL
