// Shared declarations of the particle billboard shaders (src/render/particle_draw.cpp).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/forward.h"
#include "mirage/shaderio/particle_draw.h"
#include "mirage/shaderio/particles.h"

layout(push_constant, scalar) uniform Push { ParticleDrawPush push; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleFrameRef { FrameData frame; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleRecordRef {
  RenderParticle records[];
};

#ifdef MIRAGE_PARTICLE_FRAGMENT
layout(set = 0, binding = 0) uniform sampler2D sheets[];
layout(location = 0) in vec2 inUv;              // within the tile, (0, 0) at its top left
layout(location = 1) flat in vec4 inColor;      // straight alpha, linear
layout(location = 2) flat in uint inFrame;

// The particle's colour over its billboard: the sheet's frame tile sampled at the fragment, the
// coverage its luminance (alpha from greyscale) or its alpha times the particle's.
vec4 particleColor() {
  uvec2 tiles = uvec2(push.tilesX, push.tilesY);
  uint frame = inFrame % (tiles.x * tiles.y);
  vec2 tile = vec2(frame % tiles.x, frame / tiles.x);
  vec4 t = texture(sheets[push.sheet], (tile + inUv) / vec2(tiles));
  if ((push.flags & MIRAGE_PARTICLE_ALPHA_FROM_GREY) != 0u)
    return vec4(inColor.rgb, inColor.a * dot(t.rgb, vec3(0.2126, 0.7152, 0.0722)));
  return inColor * t;
}
#endif
