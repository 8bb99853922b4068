// The per-sample test of the compute blend rasters, written once: the cluster workgroups' walks
// (cluster_raster.glsl, MIRAGE_RASTER_BLEND) and the blend queue's threads
// (cluster_blend_queue.comp) keep exactly the same covered samples as blended fragments.
#include "cluster_oit.glsl"

layout(set = 0, binding = 3) uniform sampler2D opaqueDepthImage; // image backends' depth

// Nearest opaque depth of pixel (x, y): the 64-bit buffer's high word (compute, hybrid) or the
// hardware depth (mesh, indirect); 0 (far) where nothing opaque was drawn.
float opaqueDepth(ClusterFrame f, uint x, uint y) {
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) == 0) return texelFetch(opaqueDepthImage, ivec2(x, y), 0).r;
  return bufferOpaqueDepth(f, x, y);
}

// Whether a covered sample of pixel (x, y) of its eye, at depth z, of an instance with surfel fade
// `fade` is a blended fragment: before the far plane, kept from the surfels' dither in the fade
// band, in front of the opaque surface. The eye's pixel is column x + eyeX of the target (stereo's
// right half). Blended clusters are never alpha-tested: their alpha blends in the composite.
bool blendSampleKept(ClusterFrame f, float fade, uint eyeX, uint x, uint y, float z) {
  return z >= 0.0 && meshKeepsPixel(fade, uvec2(x, y)) && z > opaqueDepth(f, x + eyeX, y);
}
