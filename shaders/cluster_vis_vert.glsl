// Body of the indirect-draw rasters (cluster_vis.vert; cluster_blend.vert over the hardware blend
// list): one instance per cluster of the pass's list, 3 vertices per triangle slot up to the
// cluster limit; slots past the cluster's triangle count collapse to a point and vanish.
#include "cluster_common.glsl"

layout(location = 0) flat out uvec2 outId;

void main() {
  uint v = listEntry(push.rasterList & 1u, rasterRange().x + gl_InstanceIndex);
  uint t = gl_VertexIndex / 3;
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  outId = uvec2(v + 1, t);
  if (t >= c.triangleCount) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0); // all three corners equal: zero area, outside the view
    return;
  }
  uint id = triangleVertex(c, t, gl_VertexIndex % 3);
  vec3 p = VertexRef(push.vertexAddress).vertices[id].position;
  mat4 model = InstanceRef(push.instanceAddress).instances[vc.instance].model;
  gl_Position = FrameRef(eyeFrameAddress()).frame.camera.viewProj * (model * vec4(p, 1.0));
}
