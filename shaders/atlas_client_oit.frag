#version 460
// The thin client's BLEND patches: each fragment in front of the opaque depth (read-only, early
// tests) appended to its pixel's list (atlas_client_oit.glsl).
#include "atlas_client_common.glsl"
#include "atlas_client_oit.glsl"
#include "atlas_client_surface.glsl"

layout(early_fragment_tests) in;

void main() { appendFragment(clientSurface()); }
