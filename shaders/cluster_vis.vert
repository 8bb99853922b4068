#version 460
// Indirect-draw visibility raster: one instance per visible cluster (body: cluster_vis_vert.glsl).
#include "cluster_vis_vert.glsl"
