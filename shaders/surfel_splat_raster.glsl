// The raster splatters' geometry stage (surfel_splat.mesh, surfel_splat.geom): disc `pair` of the
// draw is (item first + pair / views, view pair % views); its bounding square in that view (the
// texels the compute splatter visits) becomes a quad over exactly those texel centres, in a
// res × res framebuffer without attachments shared by all views (the view travels to the fragment
// shader, which turns gl_FragCoord into the texel index; no layers needed).
#include "surfel_splat_common.glsl"

struct SplatQuad {
  vec4 corners; // NDC x0, y0, x1, y1
  vec4 disc;    // centre, radius
  uvec2 ids;    // disc low word, view
};

SplatQuad splatQuad(uint pair) {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SplatQuad q;
  uint view = pair % g.viewCount;
  SplatDisc d = splatDisc(g, push.first + pair / g.viewCount);
  ivec4 square = splatSquare(g, d, view);
  // Texel x covers [x, x + 1) in pixels: the quad [lo, hi + 1] holds the centres of lo..hi only.
  q.corners = vec4(square.xy, square.zw + 1) * (2.0 / float(g.resolution)) - 1.0;
  q.disc = vec4(d.center, d.radius);
  q.ids = uvec2(d.low, view);
  return q;
}
