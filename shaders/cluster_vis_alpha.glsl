// Declarations the hardware visibility fragment shaders need for the alpha MASK test
// (fragmentAlphaKeeps, cluster_alpha.glsl): the material textures and the surface reconstruction.
#extension GL_EXT_nonuniform_qualifier : require
layout(set = 0, binding = 0) uniform sampler2D textures[];
#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_alpha.glsl"
