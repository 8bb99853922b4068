// Appending blended fragments to the per-pixel transparency lists (oit_list.glsl), shared by the compute blend
// raster (cluster_raster.glsl, MIRAGE_RASTER_BLEND), the blend queue (cluster_blend_queue.comp) and the hardware
// blend raster (cluster_blend_frag.glsl), so all write the same nodes under the same pool rule and the composite
// cannot tell them apart. Packed storage (MIRAGE_FRAME_OIT_PACKED): each of the two rasterizations
// counts or writes the fragment into its pixel's range (oitPackedFragment).

// Nearest opaque depth of pixel (x, y) in the 64-bit visibility buffer (compute, hybrid): its high
// word; 0 (far) where nothing opaque was drawn. x counts across both eyes in stereo.
float bufferOpaqueDepth(ClusterFrame f, uint x, uint y) {
  uint row = targetRowPixels(f);
  uint pixel = min(y * row + x, row * uint(f.camera.viewport.y) - 1u); // lavapipe: any lane loads
  return uintBitsToFloat(uint(VisBufferRef(push.visBufferAddress).pixels[pixel] >> 32));
}

bool oitPacked(ClusterFrame f) { return (f.flags & MIRAGE_FRAME_OIT_PACKED) != 0u; }

// A blended fragment of target pixel (x, y) already known to lie in front of the opaque surface:
// pushed onto its pixel's list under the shared pool rule and per-pixel cap (oit_list.glsl: past
// either it replaces its pixel's farthest), or in packed storage counted or written.
void oitAppend(ClusterFrame f, uint x, uint y, float z, uint id) {
  uint pixel = y * targetRowPixels(f) + x;
  if (oitPacked(f)) {
    oitPackedFragment(f.oitHeadAddress, f.oitNodeAddress, pixel, z, id);
    return;
  }
  OitSlot s = oitAcquire(f.oitCounterAddress, f.oitHeadAddress, f.oitNodeAddress, f.oitNodeCapacity, pixel, z);
  if (s.node != kOitNoNode) oitCommit(f.oitHeadAddress, f.oitNodeAddress, pixel, s, z, id, /*payload=*/false);
}
