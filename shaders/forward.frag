#version 460
// Opaque and MASK geometry, and BLEND triangles of the sorted mode (hardware "over" blending).
#include "forward_common.glsl"
#include "forward_surface.glsl"

layout(location = 0) out vec4 outColor;

void main() { outColor = shadeForwardSurface(); }
