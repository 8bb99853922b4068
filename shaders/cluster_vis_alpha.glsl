// The alpha MASK test of the hardware visibility fragment shaders: with MIRAGE_VIS_MASK (the
// *_mask.frag variants, used for scenes with MASK materials) fragmentAlphaKeeps
// (cluster_alpha.glsl) with the material textures and the surface reconstruction; without, a
// constant true, so opaque scenes run the fragment shaders without any alpha code.
#ifdef MIRAGE_VIS_MASK
#extension GL_EXT_nonuniform_qualifier : require
layout(set = 0, binding = 0) uniform sampler2D textures[];
#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_alpha.glsl"
#else
bool fragmentAlphaKeeps(uint v, uint t, vec2 fragCoord) { return true; }
#endif
