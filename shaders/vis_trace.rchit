#version 460
// Closest opaque hit: its global triangle ID and distance.
#define MIRAGE_RT_HIT_STAGE
#include "vis_trace.glsl"

layout(location = 0) rayPayloadInEXT Payload payload;

void main() {
  payload.triangle = RtSlotRef(push.slots).v[hitSlot()].firstTriangle + uint(gl_PrimitiveID);
  payload.t = gl_HitTEXT;
}
