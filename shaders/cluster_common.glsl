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

layout(push_constant, scalar) uniform Push { ClusterPush push; };

// Local 8-bit index number `i` of the global index array (packed four per word).
uint localIndex(uint i) {
  uint word = UintRef(push.indexAddress).data[i >> 2];
  return (word >> ((i & 3u) * 8u)) & 0xffu;
}

// Attribute-vertex id of corner k of triangle t of cluster c.
uint triangleVertex(GpuCluster c, uint t, uint k) {
  uint local = localIndex((c.triangleOffset + t) * 3u + k);
  return UintRef(push.clusterVertexAddress).data[c.vertexOffset + local];
}

// Number of visible clusters the rasterizers and the resolve may read.
uint visibleCount() {
  return min(CounterRef(push.counterAddress).counters.visibleClusters, FrameRef(push.frameAddress).frame.visibleCapacity);
}

// Whether a fragment of visible cluster `v` survives facing rules: single-sided materials drop back
// faces (mirrored instances swap front and back, as glTF asks); the crack-test mode keeps all.
bool keepFacing(uint v, bool frontFacing) {
  uint frameFlags = FrameRef(push.frameAddress).frame.flags;
  uint flags = InstanceRef(push.instanceAddress).instances[VisibleRef(push.visibleAddress).visible[v].instance].flags;
  if ((frameFlags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 || (flags & MIRAGE_INSTANCE_DOUBLE_SIDED) != 0) return true;
  return frontFacing != ((flags & MIRAGE_INSTANCE_MIRRORED) != 0);
}

// Sphere against the frustum planes (conservative: inside or intersecting).
bool sphereVisible(vec4 s) {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  for (int i = 0; i < 5; ++i)
    if (dot(f.planes[i].xyz, s.xyz) + f.planes[i].w < -s.w) return false;
  return true;
}
