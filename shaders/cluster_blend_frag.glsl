// Body of the hardware blend raster's fragment shaders (inId: blend-list entry + 1, triangle). The
// opaque depth is a read-only depth attachment tested GREATER before the shader runs (early tests:
// occluded fragments cost no invocation), so a fragment that runs lies in front of the opaque
// surface, as the compute blend raster's `z > opaqueDepth` asks; it is appended to its pixel's list
// with the same node (depth bits, id) under the same pool rule (cluster_oit.glsl). Facing and the
// surfels' blend band as the other hardware rasters; blended clusters are never alpha-tested.
layout(early_fragment_tests) in;

void main() {
  if (!keepFacing(inId.x - 1, gl_FrontFacing)) return;
  uvec2 p = uvec2(gl_FragCoord.xy);
  uint instance = VisibleRef(push.visibleAddress).visible[inId.x - 1].instance;
  // The surfels' pixel in the blend band, dithered by the pixel within the eye as the splat does.
  if (!meshKeepsPixel(instanceFade(instance), p - uvec2(FrameRef(push.frameAddress).frame.targetOffsetX, 0u))) return;
  uint id = (inId.x << MIRAGE_CLUSTER_TRIANGLE_BITS) | inId.y;
  oitAppend(FrameRef(push.frameAddress).frame, p.x, p.y, gl_FragCoord.z, id);
}
