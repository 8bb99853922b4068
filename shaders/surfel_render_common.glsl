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
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer SrFadeRef { float v[]; };

layout(push_constant, scalar) uniform Push { SurfelRenderPush push; };

// Quantized position (Surfel::posLo, posHi) -> the three 21-bit integer coordinates as floats.
vec3 surfelQuantized(uvec2 p) {
  const uint mask = (1u << MIRAGE_SURFEL_POSITION_BITS) - 1u;
  return vec3(float(p.x & mask), float((p.x >> 21) | ((p.y & 0x3ffu) << 11)), float(p.y >> 10));
}

// Octahedral unit normal, two snorm16 (mirage/core/octahedral.h).
vec3 surfelNormal(uint packed) {
  vec2 p = max(vec2(float(int(packed << 16) >> 16), float(int(packed) >> 16)) / 32767.0, vec2(-1.0));
  vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
  float t = max(-n.z, 0.0);
  n.x += n.x >= 0.0 ? -t : t;
  n.y += n.y >= 0.0 ? -t : t;
  return normalize(n);
}

// The instance whose visibility ids (or batches) contain `value`: the last instance whose first
// entry is <= value. Instances with nothing drawn share their first entry with the next one, so
// "last" skips them. `batches` selects firstBatch, else firstId.
uint findInstance(uint value, bool batches) {
  SrStateRef states = SrStateRef(push.stateAddress);
  uint lo = 0, hi = SrFrameRef(push.frameAddress).frame.instanceCount; // answer in [lo, hi)
  while (hi - lo > 1u) {
    uint mid = (lo + hi) >> 1;
    uint first = batches ? states.states[mid].firstBatch : states.states[mid].firstId;
    if (first <= value) lo = mid;
    else hi = mid;
  }
  return lo;
}

#include "fade_dither.glsl"
