#version 460
// Compute visibility: marking raster of OPAQUE and BLEND clusters (atlas_visibility_mark.glsl).
#include "atlas_visibility_mark.glsl"
