// Mixed scenes (docs/render.md, "Mixed scenes"): the per-instance fade the surfel prefix pass wrote
// this frame, and the per-pixel test every mesh rasterizer applies (the surfels keep the
// complementary pixels, dither < fade).
#include "fade_dither.glsl"

float instanceFade(uint instance) {
  uint64_t address = FrameRef(push.frameAddress).frame.fadeAddress;
  return address == 0 ? 0.0 : FloatRef(address).data[instance];
}

bool meshKeepsPixel(float fade, uvec2 px) { return fade <= 0.0 || fadeDither(px) >= fade; }
