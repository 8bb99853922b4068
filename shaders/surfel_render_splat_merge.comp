#version 460
// The compute splat with the subgroup merge of equal pixels (surfel_render_splat.glsl).
#define MIRAGE_SURFEL_SPLAT_MERGE
#include "surfel_render_splat.glsl"
