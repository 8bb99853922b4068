// Body of the hybrid backend's fragment shaders (inId: visible entry + 1, triangle).
void main() {
  vec2 fragCoord = targetFragCoord();
  if (!keepFacing(inId.x - 1, gl_FrontFacing) || !fragmentAlphaKeeps(eyeFrameAddress(), inId.x - 1, inId.y, fragCoord))
    return;
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  uint id = (inId.x << MIRAGE_CLUSTER_TRIANGLE_BITS) | inId.y;
  uint64_t value = (uint64_t(floatBitsToUint(gl_FragCoord.z)) << 32) | uint64_t(id);
  ivec2 p = ivec2(fragCoord);
  uint instance = VisibleRef(push.visibleAddress).visible[inId.x - 1].instance;
  // The surfels' pixel in the blend band, dithered by the pixel within the eye as the splat does.
  if (!meshKeepsPixel(instanceFade(instance), uvec2(p) - uvec2(f.targetOffsetX, 0u))) return;
  countOverdraw(f, uvec2(p));
  // Stereo: p is the pixel in the side-by-side buffer (targetFragCoord).
  atomicMax(VisBufferRef(push.visBufferAddress).pixels[p.y * int(targetRowPixels(f)) + p.x], value);
}
