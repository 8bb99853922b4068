#version 460
// Point-cloud capture, pass 2: per texel the winning disc's plane point (w = 1), its normal turned
// towards the viewer (half floats, the mesh capture's RGBA16F layout) and its colour; empty texels
// get zeros (w = 0: no surface), as the mesh capture's clear does.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/surfels.h"
#include "surfel_points.glsl"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelPointPush push; };

void main() {
  uint res = push.resolution;
  uint perView = res * res;
  uint texelCount = perView * push.viewCount;
  uint stride = gl_NumWorkGroups.x * 256;
  for (uint t = gl_GlobalInvocationID.x; t < texelCount; t += stride) {
    uint64_t key = SurfelU64Ref(push.depthKeys).v[t];
    vec4 position = vec4(0.0);
    uvec2 normal = uvec2(0);
    uint color = 0;
    if (key != ~uint64_t(0)) {
      SurfelPoint p = SurfelPointRef(push.points).v[uint(key)];
      uint view = t / perView, within = t % perView;
      PointView pv = pointView(SurfelViewRef(push.views).v[view]);
      vec3 q;
      // The splat only stores discs that are not edge-on, so the plane point exists.
      discPlanePoint(pv, texelOrigin(pv, push.center, res, within % res, within / res), p, q);
      vec3 n = dot(p.normal, pv.towardsCamera) < 0.0 ? -p.normal : p.normal;
      position = vec4(q, 1.0);
      normal = uvec2(packHalf2x16(n.xy), packHalf2x16(vec2(n.z, 0.0)));
      color = p.color;
    }
    SurfelVec4Ref(push.positions).v[t] = position;
    SurfelU32x2Ref(push.normals).v[t] = normal;
    SurfelU32Ref(push.colors).v[t] = color;
  }
}
