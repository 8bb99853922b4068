#version 460
// Debug resolve (docs/render.md, "Debug views"), run instead of cluster_resolve.comp when a debug
// view is on, so the shading resolve carries no debug code. One thread per pixel reads the
// visibility id as the resolve does and writes the view's colour (shaderio/debug_view.h):
//   clusters  a stable hash colour per (instance, cluster)
//   lod       the cluster's DAG level on a fixed ramp
//   density   triangles per pixel: 1 / the triangle's projected area in pixels, log2 ramp
//   overdraw  samples the rasters counted at the pixel before the depth test, on the step ramp
// Background pixels keep the background colour; surfels of mixed scenes are drawn grey. With
// occlusion culling it records the clusters owning pixels, as the resolve does.
#include "cluster_common.glsl"
#include "mirage/shaderio/debug_view.h"
#include "mirage/shaderio/surfel_link.h"

layout(set = 0, binding = 1) uniform usampler2D visImage;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D outImage;
layout(local_size_x = 8, local_size_y = 8) in;

// The triangle's area in pixels after projection; +inf when a corner is at or behind the eye
// plane (such a triangle reaches the near plane: far more than a pixel).
float projectedArea(ClusterFrame f, GpuCluster c, GpuClusterInstance inst, uint t) {
  mat4 mvp = f.camera.viewProj * inst.model;
  vec2 s[3];
  for (uint k = 0; k < 3u; ++k) {
    vec4 q = mvp * vec4(VertexRef(push.vertexAddress).vertices[triangleVertex(c, t, k)].position, 1.0);
    if (q.w <= 0.0) return uintBitsToFloat(0x7f800000u);
    s[k] = (q.xy / q.w * 0.5 + 0.5) * f.camera.viewport;
  }
  return 0.5 * abs((s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[1].y - s[0].y) * (s[2].x - s[0].x));
}

void main() {
  // Stereo: one dispatch over both eyes side by side, as cluster_resolve.comp: the right half uses
  // the right eye's frame (the next one), px is the pixel within the eye; the per-pixel buffers
  // (visibility, overdraw counts) span both eyes' rows.
  ivec2 target = ivec2(gl_GlobalInvocationID.xy);
  uint64_t frameAddress = push.frameAddress;
  bool stereo = (FrameRef(frameAddress).frame.flags & MIRAGE_FRAME_STEREO) != 0;
  if (stereo && target.x >= int(FrameRef(frameAddress).frame.camera.viewport.x))
    frameAddress += MIRAGE_CLUSTER_FRAME_STRIDE;
  ClusterFrame f = FrameRef(frameAddress).frame;
  ivec2 px = target - ivec2(f.targetOffsetX, 0);
  if (px.x >= int(f.camera.viewport.x) || px.y >= int(f.camera.viewport.y)) return;
  uint row = targetRowPixels(f);
  uint v1, t;
  bool surfel = false;
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) != 0) {
    uint id = uint(VisBufferRef(push.visBufferAddress).pixels[uint(target.y) * row + uint(target.x)] & 0xffffffffUL);
    surfel = f.surfelLinkAddress != 0 && (id & MIRAGE_SURFEL_ID_TAG) != 0;
    if (surfel) id = 0;
    v1 = id >> MIRAGE_CLUSTER_TRIANGLE_BITS;
    t = id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
  } else {
    uvec2 id = texelFetch(visImage, target, 0).xy;
    v1 = id.x;
    t = id.y;
  }
  // Every lane loads valid entries (background ones entry 0, triangle 0), as in the resolve:
  // lavapipe runs the loads of inactive lanes too.
  bool background = v1 == 0u;
  if (background) t = 0u;
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[background ? 0u : v1 - 1u];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  float area = projectedArea(f, c, inst, t);
  if (!background && (f.flags & MIRAGE_FRAME_OCCLUSION) != 0) { // as cluster_resolve.comp: next frame's pass 1
    uint local = c.cluster - MeshRef(push.meshAddress).meshes[inst.mesh].clusterOffset;
    if (setHistoryBitAt(inst.historyOffset + local)) {
      atomicAdd(CounterRef(push.counterAddress).counters.historyKept, 1);
      setHistoryBitAt(f.instanceHistoryBase + vc.instance);
    }
  }
  if (f.debugView == MIRAGE_DEBUG_VIEW_OVERDRAW) {
    uint n = UintRef(f.overdrawAddress).data[uint(target.y) * row + uint(target.x)];
    imageStore(outImage, target, n == 0u ? f.background : vec4(debugToLinear(debugStepColor(n - 1u)), 1.0));
    return;
  }
  if (background) {
    imageStore(outImage, target, surfel ? vec4(0.5, 0.5, 0.5, 1.0) : f.background);
    return;
  }
  vec3 rgb;
  if (f.debugView == MIRAGE_DEBUG_VIEW_CLUSTERS)
    rgb = debugClusterColor(vc.instance, c.cluster);
  else if (f.debugView == MIRAGE_DEBUG_VIEW_LOD)
    rgb = debugStepColor(c.level);
  else
    rgb = debugDensityColor(1.0 / area);
  imageStore(outImage, target, vec4(debugToLinear(rgb), 1.0));
}
