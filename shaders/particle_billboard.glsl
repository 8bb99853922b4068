// Shared declarations of the particle billboard shaders (src/render/particle_draw.cpp).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/particle_draw.h"
#include "mirage/shaderio/particles.h"
#include "mirage/shaderio/view.h"

layout(push_constant, scalar) uniform Push { ParticleDrawPush push; };
#include "particle_records.glsl"

#ifdef MIRAGE_PARTICLE_FRAGMENT
layout(set = 0, binding = 0) uniform sampler2D sheets[];
layout(location = 0) in vec2 inUv;         // within the tile, (0, 0) at its top left
layout(location = 1) flat in vec4 inColor; // straight alpha, linear
layout(location = 2) flat in uint inFrame;
layout(location = 3) flat in uvec4 inSheet; // sheet, tilesX, tilesY, flags (MIRAGE_PARTICLE_*)

// The particle's colour over its billboard: the sheet's frame tile sampled at the fragment, the
// coverage its luminance (alpha from greyscale) or its alpha times the particle's.
vec4 particleColor() {
  uvec2 tiles = inSheet.yz;
  vec4 t = texture(sheets[nonuniformEXT(inSheet.x)], (particleTile(inFrame, tiles) + inUv) / vec2(tiles));
  return particleShade(inColor, t, inSheet.w);
}
#endif
