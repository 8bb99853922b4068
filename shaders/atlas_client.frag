#version 460
// The thin client's opaque and MASK patches, depth-tested and written (reverse-Z).
#include "atlas_client_common.glsl"
#include "atlas_client_surface.glsl"

layout(location = 0) out vec4 outColor;

void main() { outColor = clientSurface(); }
