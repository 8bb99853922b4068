// Body of the mesh-shader rasters (cluster_vis.mesh; cluster_blend.mesh over the hardware blend
// list): one workgroup per cluster of the pass's list (push.rasterList), (list entry + 1, triangle)
// per primitive.
#include "cluster_common.glsl"

layout(local_size_x = 32) in;
layout(triangles, max_vertices = MIRAGE_CLUSTER_MAX_VERTICES, max_primitives = MIRAGE_CLUSTER_MAX_TRIANGLES) out;
layout(location = 0) perprimitiveEXT flat out uvec2 outId[];

void main() {
  uint v = rasterEntry(gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x);
  if (v == ~0u) {
    SetMeshOutputsEXT(0, 0);
    return;
  }
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  mat4 mvp = FrameRef(eyeFrameAddress()).frame.camera.viewProj * InstanceRef(push.instanceAddress).instances[vc.instance].model;
  SetMeshOutputsEXT(c.vertexCount, c.triangleCount);
  for (uint i = gl_LocalInvocationIndex; i < c.vertexCount; i += 32) {
    uint id = UintRef(push.clusterVertexAddress).data[c.vertexOffset + i];
    vec3 p = VertexRef(push.vertexAddress).vertices[id].position;
    gl_MeshVerticesEXT[i].gl_Position = mvp * vec4(p, 1.0);
  }
  for (uint t = gl_LocalInvocationIndex; t < c.triangleCount; t += 32) {
    uint b = (c.triangleOffset + t) * 3u;
    gl_PrimitiveTriangleIndicesEXT[t] = uvec3(localIndex(b), localIndex(b + 1), localIndex(b + 2));
    outId[t] = uvec2(v + 1, t);
  }
}
