// Shared declarations of the cluster-LOD shaders: every array through a buffer device address in
// ClusterPush (include/mirage/shaderio/cluster.h), and helpers to fetch a cluster's triangles.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/cluster.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer FrameRef { ClusterFrame frame; };
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
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ConeRef { GpuClusterCone cones[]; };
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

// A cluster to draw in the current pass: into the hardware list (hybrid, large triangles) or the
// up list, counted. False when the lists are full.
bool emitCluster(VisibleCluster vc, vec4 worldSphere, uint triangles, ClusterFrame f) {
  bool hardware = (f.flags & MIRAGE_FRAME_HYBRID) != 0 && hardwareCluster(worldSphere, triangles, f);
  if (!appendVisible(hardware ? MIRAGE_LIST_DOWN : MIRAGE_LIST_UP, vc)) return false;
  CounterRef counters = CounterRef(push.counterAddress);
  atomicAdd(counters.counters.trianglesSelected, triangles);
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
