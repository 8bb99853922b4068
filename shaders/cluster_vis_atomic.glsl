// Body of the hybrid backend's fragment shaders (inId: visible entry + 1, triangle).
void main() {
  if (!keepFacing(inId.x - 1, gl_FrontFacing) || !fragmentAlphaKeeps(inId.x - 1, inId.y, gl_FragCoord.xy)) return;
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  uint id = (inId.x << MIRAGE_CLUSTER_TRIANGLE_BITS) | inId.y;
  uint64_t value = (uint64_t(floatBitsToUint(gl_FragCoord.z)) << 32) | uint64_t(id);
  ivec2 p = ivec2(gl_FragCoord.xy);
  uint instance = VisibleRef(push.visibleAddress).visible[inId.x - 1].instance;
  // The surfels' pixel in the blend band, dithered by the pixel within the eye as the splat does.
  if (!meshKeepsPixel(instanceFade(instance), uvec2(p) - uvec2(f.targetOffsetX, 0u))) return;
  countOverdraw(f, uvec2(p));
  // Stereo draws each eye with its viewport in its half, so p is already the buffer's column.
  atomicMax(VisBufferRef(push.visBufferAddress).pixels[p.y * int(targetRowPixels(f)) + p.x], value);
}
