// The alpha MASK test of the hardware visibility fragment shaders: with MIRAGE_VIS_MASK (the
// *_mask.frag variants, used for scenes with MASK materials) fragmentAlphaKeeps
// (cluster_alpha.glsl) with the material textures and the surface reconstruction; without, a
// constant true, so opaque scenes run the fragment shaders without any alpha code.

// The fragment's pixel in the side-by-side layout of the stereo targets, as the eye frames'
// targetOffsetX and the 64-bit buffer's rows count it: per-eye viewports put the right eye there
// already; multiview draws it into its own layer, one eye's width to the left.
vec2 targetFragCoord() {
  if (MIRAGE_VIEW_INDEX == 0) return gl_FragCoord.xy;
  return gl_FragCoord.xy + vec2(float(MIRAGE_VIEW_INDEX) * FrameRef(push.frameAddress).frame.camera.viewport.x, 0.0);
}

#ifdef MIRAGE_VIS_MASK
#extension GL_EXT_nonuniform_qualifier : require
layout(set = 0, binding = 0) uniform sampler2D textures[];
#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_alpha.glsl"
#else
bool fragmentAlphaKeeps(uint64_t frameAddress, uint v, uint t, vec2 fragCoord) { return true; }
#endif
