// Coverage of the compute rasterizers (cluster_raster.glsl) and the blend queue
// (cluster_blend_queue.comp): a triangle's sample box and its edge functions on the snapped grid,
// written once so that a triangle walked by its cluster's workgroup and one spread over the blend
// queue's tiles cover exactly the same samples with exactly the same depths.
//
// Edge functions on the snapped grid. The vertices sit on the 1/256-pixel grid (toScreen), so as
// integers on that grid the edge functions are exact, as fixed-function hardware's are: two
// triangles sharing an edge get exactly opposite values at every sample (the top-left rule then
// gives each sample to one of them: no cracks, no double blends), and since they are linear the
// walks step them by integer adds alone (no per-sample products, no rounding). The inside test
// folds the top-left rule into a bias: w > 0, or w == 0 on a top-left edge, is w + bias >= 0 with
// bias -1 on the other edges. Three walks by size, each exact in its integer width:
// - walkSmall (nearly all triangles, queued or not): extent under 63 pixels, 32-bit;
// - walkLarge (larger queued boxes, near-clipped triangles) and the blend queue: coordinates
//   within 2^21 pixels, 64-bit (edgeCorners64, keepsFacing, edgeWalk64; edgeSetup64 all three);
// - walkFloat: the rest (vertices a hair in front of the near plane project millions of pixels
//   away), float edge functions evaluated from canonically ordered endpoints.
// Exact integers do not depend on where a walk starts, so every walk gives a sample the same
// values, and the same depth: edgeDepth(vec3(w), zw) with zw from the same area.
// MIRAGE_RASTER_SMALL_EXTENT (63 pixels: 32-bit values stay below 2^30) is in cluster_common.glsl,
// whose lean-raster test predicts the walks.
#define MIRAGE_RASTER_SNAP 256.0
#define MIRAGE_RASTER_LARGE_COORD 2097152.0 // pixels (2^21): 64-bit values stay below 2^60

// Top-left rule of an edge with direction d (= v - u, inside on the positive side): a top edge
// (horizontal, pointing right with y down) or a left edge (pointing up).
bool topLeft(vec2 d) { return (d.y == 0.0 && d.x > 0.0) || d.y < 0.0; }
bool topLeft(ivec2 d) { return (d.y == 0 && d.x > 0) || d.y < 0; }
bool topLeft(i64vec2 d) { return (d.y == 0 && d.x > 0) || d.y < 0; }

// Whether a triangle of (doubled, signed) area `area` is drawn: Vulkan, y down: counter-clockwise
// (front) has a negative area here.
bool keepsFacing(float area, bool keepAll, bool mirrored) {
  return area != 0.0 && (keepAll || (area < 0.0) != mirrored);
}

// The pixel box of a triangle's samples (x + 0.5, y + 0.5) on screen; empty when hi < lo.
void sampleBox(vec3 a, vec3 b, vec3 c, vec2 viewport, out vec2 lo, out vec2 hi) {
  lo = max(floor(min(a.xy, min(b.xy, c.xy)) - 0.5), vec2(0.0));
  hi = min(ceil(max(a.xy, max(b.xy, c.xy)) - 0.5), viewport - 1.0);
}

// A triangle's 64-bit edge functions (w.x weighs a, w.y b, w.z c): their values at the sample of
// pixel `first`, their steps per `stride` pixels in x and in y, and the depth weights.
struct EdgeWalk64 {
  i64vec3 w0, dx, dy;
  vec3 zw; // the sample's depth is edgeDepth(vec3(w), zw)
};

// A triangle's corners on the snapped grid relative to the sample of pixel `first`, and its doubled
// signed area there (its facing: keepsFacing).
struct EdgeCorners64 {
  i64vec2 a, b, c;
  int64_t area;
};
EdgeCorners64 edgeCorners64(vec3 a, vec3 b, vec3 c, vec2 first) {
  i64vec2 o = i64vec2((first + 0.5) * MIRAGE_RASTER_SNAP);
  i64vec2 A = i64vec2(a.xy * MIRAGE_RASTER_SNAP) - o, B = i64vec2(b.xy * MIRAGE_RASTER_SNAP) - o;
  i64vec2 C = i64vec2(c.xy * MIRAGE_RASTER_SNAP) - o;
  return EdgeCorners64(A, B, C, (B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x));
}

// The edge walk of a triangle with corners k (of a drawn facing, nonzero area), oriented so that
// inside is positive on all three edges.
EdgeWalk64 edgeWalk64(EdgeCorners64 k, vec3 a, vec3 b, vec3 c, uvec2 stride) {
  i64vec2 A = k.a, B = k.b, C = k.c;
  int64_t area = k.area;
  if (area < 0) {
    i64vec2 tmp = B;
    B = C;
    C = tmp;
    vec3 tz = b;
    b = c;
    c = tz;
    area = -area;
  }
  // Edge (u, v) at sample p: (v.x - u.x)(p.y - u.y) - (v.y - u.y)(p.x - u.x).
  i64vec3 ex = i64vec3(C.x - B.x, A.x - C.x, B.x - A.x), ey = i64vec3(C.y - B.y, A.y - C.y, B.y - A.y);
  EdgeWalk64 e;
  e.w0 = i64vec3(ey.x * B.x - ex.x * B.y, ey.y * C.x - ex.y * C.y, ey.z * A.x - ex.z * A.y);
  e.w0 += i64vec3(topLeft(i64vec2(ex.x, ey.x)) ? 0 : -1, topLeft(i64vec2(ex.y, ey.y)) ? 0 : -1,
                  topLeft(i64vec2(ex.z, ey.z)) ? 0 : -1);
  e.dx = -ey * (int64_t(MIRAGE_RASTER_SNAP) * int64_t(stride.x));
  e.dy = ex * (int64_t(MIRAGE_RASTER_SNAP) * int64_t(stride.y));
  e.zw = vec3(a.z, b.z, c.z) / float(area);
  return e;
}

// Set-up of a triangle with coordinates within MIRAGE_RASTER_LARGE_COORD, oriented so that inside
// is positive on all three edges; false when its facing is not drawn (or it has no area).
bool edgeSetup64(vec3 a, vec3 b, vec3 c, vec2 first, uvec2 stride, bool keepAll, bool mirrored, out EdgeWalk64 e) {
  EdgeCorners64 k = edgeCorners64(a, b, c, first);
  if (!keepsFacing(float(k.area), keepAll, mirrored)) return false;
  e = edgeWalk64(k, a, b, c, stride);
  return true;
}

// Whether a sample with edge values w is covered (the top-left rule is in the bias).
bool edgeInside(i64vec3 w) { return (w.x | w.y | w.z) >= 0; }

// The depth of a covered sample.
float edgeDepth(vec3 w, vec3 zw) { return dot(w, zw); }
