#version 460
// Opaque depth for the hardware blend raster on the buffer backends (compute, hybrid): the 64-bit
// visibility buffer's depth word written to the depth attachment, bit for bit (D32_SFLOAT holds the
// float as is), so the blend draw's early depth test compares against exactly the depth the compute
// blend raster reads (cluster_oit.glsl).
#include "cluster_common.glsl"
#include "cluster_oit.glsl"

void main() {
  uvec2 p = uvec2(gl_FragCoord.xy);
  gl_FragDepth = bufferOpaqueDepth(FrameRef(push.frameAddress).frame, p.x, p.y);
}
