#version 460
// Compute visibility: marking raster of MASK clusters, each sample alpha-tested first
// (atlas_visibility_mark.glsl; cluster_raster.glsl's MIRAGE_RASTER_MASK).
#define MIRAGE_RASTER_MASK 1
#include "atlas_visibility_mark.glsl"
