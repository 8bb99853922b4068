// Shared declarations of the surfel-render shaders: every array through a buffer device address in
// SurfelRenderPush (include/mirage/shaderio/surfel_render.h), and the helpers several passes need.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/surfel_render.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SrFrameRef { SurfelRenderFrame frame; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SrCloudRef { SurfelRenderCloud clouds[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SrInstanceRef { SurfelRenderInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SrStateRef { SurfelInstanceState states[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer SrUvec2Ref { uvec2 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SrMaterialRef { GpuMaterial materials[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SrCounterRef { SurfelRenderCounters c; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SrDrawRef { uvec4 draws[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer SrVisRef { uint64_t pixels[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SrFloatRef { float v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SrUintRef { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer SrFadeRef { float v[]; };

layout(push_constant, scalar) uniform Push { SurfelRenderPush push; };

#include "surfel_decode.glsl"

// The instance whose visibility ids contain `id`: the last instance whose first id is <= id.
// Instances with nothing drawn share their first id with the next one, so "last" skips them.
uint findInstance(uint id) {
  SrStateRef states = SrStateRef(push.stateAddress);
  uint lo = 0, hi = SrFrameRef(push.frameAddress).frame.instanceCount; // answer in [lo, hi)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) >> 1;
    if (states.states[mid].firstId <= id) lo = mid;
    else hi = mid;
  }
  return lo;
}

#include "fade_dither.glsl"

// True when a surfel of the instance faces away from the eye by more than the culling margin
// (dot(n, v) > cos * |v| with v from the eye to the surfel, all in the cloud's object frame).
bool surfelBackFacing(SurfelInstanceState s, vec3 quantized, uint packedNormal) {
  vec3 v = (quantized - s.eyeQuantized.xyz) * s.quantStep.xyz;
  return dot(surfelNormal(packedNormal), v) > MIRAGE_SURFEL_BACKFACE_COS * length(v);
}

// Oriented discs (MIRAGE_SURFEL_ORIENTED): a surfel is a disc of radius R in its tangent plane.
// Projected around its centre (first order) it is an ellipse: radius R across m, the screen
// direction of its normal, and R·|cos θ| along m, θ between the normal and the view ray (the minor
// radius kept >= MIRAGE_SURFEL_MIN_MINOR_PX). Returns (m, k): a pixel offset d from the centre lies
// inside when |d|² + (k - 1)·(d·m)² <= R², k = (R / minor)² (1: the facing circle). Angles are taken
// in the cloud's object frame (exact for rotations and uniform scales of the instance).
vec3 surfelEllipse(SurfelInstanceState s, vec3 quantized, vec4 clip, uint packedNormal, float radius, vec2 viewport) {
  vec3 n = surfelNormal(packedNormal);
  vec3 v = (quantized - s.eyeQuantized.xyz) * s.quantStep.xyz;
  float c = abs(dot(n, v)) / max(length(v), 1e-30);
  vec4 dclip = s.clipFromQuantized * vec4(n / s.quantStep.xyz, 0.0);
  // Screen-space derivative of the projection along n (up to a positive factor 1 / w²).
  vec2 m = (dclip.xy * clip.w - clip.xy * dclip.w) * viewport;
  float len = length(m);
  if (!(len > 0.0) || isinf(len)) return vec3(1.0, 0.0, 1.0); // normal along the view ray: a circle
  float minor = max(radius * c, min(radius, MIRAGE_SURFEL_MIN_MINOR_PX));
  return vec3(m / len, (radius * radius) / (minor * minor));
}

// Whether pixel offset d lies in the disc of radius `radius` squashed by `ellipse` (surfelEllipse).
bool insideSurfelDisc(vec2 d, float radius, vec3 ellipse) {
  float a = dot(d, ellipse.xy);
  return dot(d, d) + (ellipse.z - 1.0) * a * a <= radius * radius;
}
