// Body of the image backends' visibility fragment shaders (inId: visible entry + 1, triangle).
layout(location = 0) out uvec2 outVis;

void main() {
  if (!keepFacing(inId.x - 1, gl_FrontFacing) || !fragmentAlphaKeeps(inId.x - 1, inId.y, gl_FragCoord.xy)) discard;
  // No early_fragment_tests: with this store the depth test runs after the shader (overdraw counts
  // every covered sample).
  countOverdraw(FrameRef(push.frameAddress).frame, uvec2(gl_FragCoord.xy));
  outVis = inId;
}
