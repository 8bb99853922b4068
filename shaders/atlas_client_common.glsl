// Shared declarations of the thin client's shaders (render/atlas_client.h, docs/stream.md, "The client's renderer").
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/forward.h" // MIRAGE_ALPHA_*
#include "mirage/shaderio/atlas_client.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ViewRef { ViewFrame view; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer PatchRef { GpuClientPatch patches[]; };

layout(push_constant, scalar) uniform Push { AtlasClientPush push; };

// An RGBA8 colour as the atlas holds it (sRGB rgb, linear alpha; r in the low byte) in linear.
vec4 decodeAtlasColor(uint rgba8) {
  vec4 c = unpackUnorm4x8(rgba8);
  return vec4(mix(c.rgb / 12.92, pow((c.rgb + 0.055) / 1.055, vec3(2.4)), greaterThan(c.rgb, vec3(0.04045))), c.a);
}
