#version 460
// Cluster selection: LOCALCUT (draw iff self error <= tau < parent error, both projected to pixels)
// and frustum culling, one thread per (visible instance, cluster of the instance's level range from
// the cull pass). Still linear in the clusters of the kept levels; a BVH over groups
// (vk_lod_clusters) or DAG traversal makes it sublinear (docs/render.md).
#include "cluster_common.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

// Object-space error of a sphere projected to pixels at the sphere's nearest point:
// err / max(dist - r, znear) * |proj[1][1]| * 0.5 * height. A camera inside the sphere sees an
// unbounded error: refine. Zero errors stay zero (level 0 cannot refine). Parent
// spheres contain their children's and parent errors are larger, so the projection stays monotonic
// from child to parent and the cut stays crack-free.
float projectedError(vec4 sphere, float error, GpuClusterInstance inst, ClusterFrame f) {
  if (error <= 0.0 || isinf(error)) return error;
  vec3 c = (inst.model * vec4(sphere.xyz, 1.0)).xyz;
  float d = length(c - f.eye.xyz) - sphere.w * inst.maxScale;
  if (d <= 0.0) return uintBitsToFloat(0x7f800000u);
  return error * inst.maxScale / max(d, f.znear) * f.errorScale;
}

void main() {
  CounterRef counters = CounterRef(push.counterAddress);
  VisibleInstance vi = VisibleInstanceRef(push.visibleInstanceAddress).entries[gl_WorkGroupID.y];
  uint instanceIndex = vi.instance;
  uint local = gl_GlobalInvocationID.x;
  if (local >= vi.clusterCount) return;
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[instanceIndex];
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];
  atomicAdd(counters.counters.clustersTested, 1);
  uint ci = mesh.clusterOffset + vi.firstCluster + local;
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[ci];
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  bool onCut = projectedError(c.selfSphere, c.selfError, inst, f) <= f.tau &&
               projectedError(c.parentSphere, c.parentError, inst, f) > f.tau;
  if (!onCut) return;
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0) {
    vec4 s = vec4((inst.model * vec4(c.boundsSphere.xyz, 1.0)).xyz, c.boundsSphere.w * inst.maxScale);
    if (!sphereVisible(s)) {
      atomicAdd(counters.counters.clustersFrustumCulled, 1);
      return;
    }
  }
  uint slot = atomicAdd(counters.counters.visibleClusters, 1);
  if (slot >= f.visibleCapacity) {
    atomicAdd(counters.counters.clustersOverflow, 1);
    return;
  }
  VisibleRef(push.visibleAddress).visible[slot] = VisibleCluster(instanceIndex, ci);
  atomicAdd(counters.counters.trianglesSelected, c.triangleCount);
}
