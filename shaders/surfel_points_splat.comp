#version 460
// Point-cloud capture, pass 1: every (point, view) splats its oriented disc into the view's
// texels with atomicMin((depth bits << 32) | point) on a 64-bit buffer: the nearest disc wins,
// ties to the smaller point index, so the result is independent of execution order. A compute
// splat instead of rasterized sprites: no multiview limits, no pass splits, the same code on
// lavapipe and on GPUs with weak fixed-function raster (the H200), and deterministic ties.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#include "mirage/shaderio/surfels.h"
#include "surfel_points.glsl"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelPointPush push; };

void main() {
  uint view = gl_WorkGroupID.y;
  PointView pv = pointView(SurfelViewRef(push.views).v[view]);
  uint res = push.resolution;
  float pixelsPerWorld = float(res) / (2.0 * push.center.w);
  uint viewBase = view * res * res; // V·res² < 2^32 (checked by the capture)
  uint stride = gl_NumWorkGroups.x * 256;
  for (uint i = gl_GlobalInvocationID.x; i < push.pointCount; i += stride) {
    SurfelPoint p = SurfelPointRef(push.points).v[i];
    // A closed scan's back-facing discs would poke out past the silhouette with inward normals
    // (a mesh's back faces never do): with oriented normals they are left to the views they face.
    if (push.cullBackFacing != 0 && dot(p.normal, pv.towardsCamera) <= 0.0) continue;
    // The disc's bounding box on screen: its extent along an axis a is r·sqrt(1 - (n·a)²).
    vec3 rel = p.position - push.center.xyz;
    vec2 pixel = (vec2(dot(rel, pv.right), -dot(rel, pv.up)) / push.center.w * 0.5 + 0.5) * float(res);
    float nr = dot(p.normal, pv.right), nu = dot(p.normal, pv.up);
    vec2 extent = p.radius * sqrt(max(vec2(1.0 - nr * nr, 1.0 - nu * nu), 0.0)) * pixelsPerWorld;
    ivec2 lo = max(ivec2(ceil(pixel - extent - 0.5)), ivec2(0));
    ivec2 hi = min(ivec2(floor(pixel + extent - 0.5)), ivec2(res) - 1);
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) {
        vec3 q;
        if (!discPlanePoint(pv, texelOrigin(pv, push.center, res, uint(x), uint(y)), p, q)) continue;
        vec3 off = q - p.position;
        if (dot(off, off) > p.radius * p.radius) continue;
        uint texel = viewBase + uint(y) * res + uint(x);
        if (push.previousLayer != 0ul) {
          // Depth peeling: only what lies behind the previous layer's surface at this texel.
          vec4 previous = SurfelVec4Ref(push.previousLayer).v[texel];
          if (previous.w == 0.0 || dot(previous.xyz - q, pv.towardsCamera) <= push.peelEpsilon) continue;
        }
        uint64_t key = (uint64_t(floatBitsToUint(pointDepth(pv, push.center, q))) << 32) | uint64_t(i);
        atomicMin(SurfelU64Ref(push.depthKeys).v[texel], key);
      }
  }
}
