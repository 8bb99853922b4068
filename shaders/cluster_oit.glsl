// Appending blended fragments to the per-pixel transparency lists (oit_list.glsl), shared by the compute blend
// raster (cluster_raster.glsl, MIRAGE_RASTER_BLEND), the blend queue (cluster_blend_queue.comp) and the hardware
// blend raster (cluster_blend_frag.glsl), so all write the same nodes under the same pool rule and the composite
// cannot tell them apart. Packed storage (MIRAGE_FRAME_OIT_PACKED): each of the two rasterizations
// counts or writes the fragment into its pixel's range (oitPackedFragment), or the first writes it
// into its pixel's fixed slots (oitFixedFragment).

// Nearest opaque depth of pixel (x, y) in the 64-bit visibility buffer (compute, hybrid): its high
// word; 0 (far) where nothing opaque was drawn. x counts across both eyes in stereo.
float bufferOpaqueDepth(ClusterFrame f, uint x, uint y) {
  uint row = targetRowPixels(f);
  uint pixel = min(y * row + x, row * uint(f.camera.viewport.y) - 1u); // lavapipe: any lane loads
  return uintBitsToFloat(uint(VisBufferRef(push.visBufferAddress).pixels[pixel] >> 32));
}

bool oitPacked(ClusterFrame f) { return (f.flags & MIRAGE_FRAME_OIT_PACKED) != 0u; }

// Packed storage in fixed slots (ClusterFrame::oitFixedSlots; shaderio/oit.h, MIRAGE_OIT_FIXED_*):
// the frame's state as this workgroup found it (oitBeginBlendPass), which tells the first
// rasterization from the second. 0 in every other frame.
uint oitFixedState = 0u;

// Called by each workgroup of a compute blend pass (the compute blend raster, the blend queue)
// before it appends: reads the fixed-slot state once (uniform over the workgroup), and returns
// false where the workgroup has nothing to do: the second rasterization of a fixed-slot frame in
// which every pixel's fragments fit its slots.
bool oitBeginBlendPass(ClusterFrame f) {
  if (!oitPacked(f) || f.oitFixedSlots == 0u) return true;
  oitFixedState = OitCounterRef(f.oitCounterAddress).counters.fixedState;
  return (oitFixedState & MIRAGE_OIT_FIXED_SECOND) == 0u || (oitFixedState & MIRAGE_OIT_FIXED_OVER) != 0u;
}

// A fragment of `pixel` in packed storage: in fixed slots in a fixed-slot frame's first
// rasterization, else counted or written into its range.
void oitPackedAppend(ClusterFrame f, uint pixel, float z, uint id) {
  if (f.oitFixedSlots != 0u && (oitFixedState & MIRAGE_OIT_FIXED_SECOND) == 0u)
    oitFixedFragment(f.oitHeadAddress, f.oitNodeAddress, f.oitCounterAddress, f.oitFixedSlots, f.oitFixedStride,
                     pixel, z, id);
  else
    oitPackedFragment(f.oitHeadAddress, f.oitNodeAddress, pixel, z, id);
}

// A blended fragment of target pixel (x, y) already known to lie in front of the opaque surface:
// pushed onto its pixel's list under the shared pool rule and per-pixel cap (oit_list.glsl: past
// either it replaces its pixel's farthest), or in packed storage counted or written.
void oitAppend(ClusterFrame f, uint x, uint y, float z, uint id) {
  uint pixel = y * targetRowPixels(f) + x;
  if (oitPacked(f)) {
    oitPackedAppend(f, pixel, z, id);
    return;
  }
  OitSlot s = oitAcquire(f.oitCounterAddress, f.oitHeadAddress, f.oitNodeAddress, f.oitNodeCapacity, pixel, z);
  if (s.node != kOitNoNode) oitCommit(f.oitHeadAddress, f.oitNodeAddress, pixel, s, z, id, /*payload=*/false);
}
