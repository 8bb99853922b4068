// The thin client's surface colour: the atlas texel (the texture is sRGB, so sampling decodes and
// filters in linear), or a colour-only patch's colour. MASK: the server writes coverage into alpha,
// pixels under half are cut. Alpha is 1 except for BLEND patches.
layout(set = 0, binding = 0) uniform sampler2D atlas;

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in uint inFlags;
layout(location = 2) flat in uint inColor;

vec4 clientSurface() {
  vec4 c;
  if ((inFlags & MIRAGE_CLIENT_COLOR_ONLY) != 0u) {
    c = decodeAtlasColor(inColor);
  } else {
    c = texture(atlas, inUv);
  }
  uint mode = inFlags & MIRAGE_CLIENT_ALPHA_MASK;
  if (mode == MIRAGE_ALPHA_MASK && c.a < 0.5) discard;
  if (mode != MIRAGE_ALPHA_BLEND) c.a = 1.0;
  return c;
}
