// Body of the image backends' visibility fragment shaders (inId: visible entry + 1, triangle).
layout(location = 0) out uvec2 outVis;

void main() {
  if (!keepFacing(inId.x - 1, gl_FrontFacing) || !fragmentAlphaKeeps(eyeFrameAddress(), inId.x - 1, inId.y, targetFragCoord()))
    discard;
#ifdef MIRAGE_VIS_OVERDRAW // *_overdraw.frag: no early_fragment_tests, so the depth test follows this store
  countOverdraw(FrameRef(push.frameAddress).frame, uvec2(gl_FragCoord.xy));
#endif
  outVis = inId;
}
