// Ordered dither in [0, 1) per pixel (interleaved gradient noise, Jimenez 2014), shared by the
// surfel splat and the cluster rasterizers: in a mesh/surfel blend band with fade f the surfels
// keep the pixels whose dither is below f and the mesh the others, so the two never overlap and
// never leave a hole (docs/render.md, "Mixed scenes").
#ifndef MIRAGE_FADE_DITHER_GLSL
#define MIRAGE_FADE_DITHER_GLSL
float fadeDither(uvec2 px) { return fract(52.9829189 * fract(0.06711056 * float(px.x) + 0.00583715 * float(px.y))); }
#endif
