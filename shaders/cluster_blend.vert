#version 460
// Hardware blend raster through indirect draws: cluster_vis.vert over the hardware blend list.
#define MIRAGE_BLEND_LISTS 1
#include "cluster_vis_vert.glsl"
