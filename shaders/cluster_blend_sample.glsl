// The per-sample test of the compute blend rasters, written once: the cluster workgroups' walks
// (cluster_raster.glsl, MIRAGE_RASTER_BLEND) and the blend queue's threads
// (cluster_blend_queue.comp) keep exactly the same covered samples as blended fragments.
#include "cluster_oit.glsl"

layout(set = 0, binding = 3) uniform sampler2D opaqueDepthImage; // image backends' depth
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer BlendQueueRef { BlendQueueTriangle triangles[]; };

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

// MIRAGE_OIT_COMPOSITE_SHADED (specialization constant 2 of both compute blend rasters): each kept
// fragment is shaded where it is rasterized and its colour (RGBA16F) stored beside its node, its id
// then tagged as a particle's (node + 1 | MIRAGE_OIT_COLOR_ID_TAG), so the composite only sorts and
// blends. Needs shading.glsl and cluster_surface.glsl (textures[] bound) before this file.
layout(constant_id = 2) const bool kBlendShaded = false;
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorOutRef { uvec2 colors[]; };

// A kept fragment of pixel p of its eye (target column p.x + eyeX, buffer pixel `pixel`) written
// into slot s (oitAcquire / oitSlotOf): shaded first under kBlendShaded.
void commitBlendFragment(ClusterFrame f, uint eyeX, uvec2 p, uint pixel, OitSlot s, float z, uint id) {
  if (s.node == kOitNoNode) return;
  if (kBlendShaded) {
    ClusterFrame eye = FrameRef(push.frameAddress + (eyeX != 0u ? MIRAGE_CLUSTER_FRAME_STRIDE : 0u)).frame;
    VisibleCluster vc = VisibleRef(push.visibleAddress).visible[(id >> MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u];
    vec4 c = shadeClusterPixel(eye, vc, id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u), ivec2(p), /*lean=*/true);
    OitColorOutRef(f.oitColorAddress).colors[s.node] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
    id = (s.node + 1u) | MIRAGE_OIT_COLOR_ID_TAG;
  }
  oitCommit(f.oitHeadAddress, f.oitNodeAddress, pixel, s, z, id, /*payload=*/kBlendShaded);
}
