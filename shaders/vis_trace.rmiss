#version 460
#include "vis_trace.glsl"

layout(location = 0) rayPayloadInEXT Payload payload;

void main() { payload.triangle = MIRAGE_RT_NO_HIT; }
