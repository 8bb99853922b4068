// Compute splat (Schütz et al. 2021): one workgroup per batch of MIRAGE_SURFEL_BATCH surfels of one
// instance, each thread MIRAGE_SURFEL_PER_THREAD surfels strided by the workgroup size so every
// position load (8 bytes: the quantized position only) is coalesced. A surfel is a disc of
// `radiusPixels / w` pixels around its projection: pixels whose centre lies inside it take
// atomicMax(reverse-Z depth bits << 32 | id) on the 64-bit visibility buffer (larger is nearer),
// and so does the pixel holding the projection (the nearest centre). Discs under half a pixel take
// the fast path: that one pixel, one atomic (a sample within the disc's radius of a pixel centre
// then lies inside that pixel, so the covering argument still holds). A plain
// load first skips the atomic when a nearer surfel is already there (most are, at high density).
// Compiled twice: surfel_render_splat.comp and surfel_render_splat_merge.comp (MIRAGE_SURFEL_SPLAT_MERGE,
// the subgroup merge below; a separate module so the plain splat needs no subgroup shuffles).
#extension GL_EXT_shader_atomic_int64 : require
#ifdef MIRAGE_SURFEL_SPLAT_MERGE
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#endif
#include "surfel_render_common.glsl"

layout(local_size_x = MIRAGE_SURFEL_SPLAT_WORKGROUP) in;

// Back-face culling as a pipeline variant: without it the normal loads and their registers fold
// away (measured on the H200, the culling code slowed the unculled splat by 7 %).
layout(constant_id = 0) const bool kCullBackFaces = false;
// Eyes splatted (1, or 2 in stereo): a constant, so the mono pipeline carries no stereo code.
layout(constant_id = 1) const int kEyes = 1;

// Where one eye's pixels go: its size, the buffer's row length (both eyes in stereo) and the
// column its half starts at.
struct EyeTarget {
  uint width, height, row, offsetX;
};

// px is the pixel within the eye: the blend-band dither is the mono frame's in either eye.
void splatPixel(SrVisRef vis, uvec2 px, EyeTarget t, uint64_t value, float fade) {
  if (fade < 1.0 && fadeDither(px) >= fade) return; // the mesh's pixel in the blend band
  uint at = px.y * t.row + px.x + t.offsetX;
  if (vis.pixels[at] >= value) return;
  atomicMax(vis.pixels[at], value);
}

// The disc's other pixels: centres c (integer + 0.5) with |c - p| <= radius, except the pixel
// holding the projection p (which the caller writes, directly or through the subgroup merge).
// `shape` squashes the disc into its projected ellipse (discShape).
void splatDiscRest(SrVisRef vis, vec2 p, float radius, vec3 shape, EyeTarget t, uint64_t value, float fade) {
  ivec2 lo = max(ivec2(ceil(p - radius - 0.5)), ivec2(0));
  ivec2 hi = min(ivec2(floor(p + radius - 0.5)), ivec2(t.width, t.height) - 1);
  ivec2 own = ivec2(floor(p));
  for (int y = lo.y; y <= hi.y; ++y) {
    float dy = float(y) + 0.5 - p.y;
    for (int x = lo.x; x <= hi.x; ++x) {
      float dx = float(x) + 0.5 - p.x;
      if (insideSurfelDisc(vec2(dx, dy), radius, shape) && ivec2(x, y) != own)
        splatPixel(vis, uvec2(x, y), t, value, fade);
    }
  }
}

// The disc's shape on screen (surfelEllipse): the facing circle unless oriented discs are on and
// the disc is large enough for its orientation to matter (only then is the normal read).
vec3 discShape(SurfelInstanceState s, SurfelRenderFrame f, vec3 quantized, vec4 clip, float radius, uint surfel) {
  if ((f.flags & MIRAGE_SURFEL_ORIENTED) == 0u || radius < MIRAGE_SURFEL_ORIENTED_MIN_RADIUS_PX)
    return vec3(1.0, 0.0, 1.0);
  uint normal = SrUvec2Ref(push.attributeAddress).v[s.firstSurfel + surfel].x;
  return surfelEllipse(s, quantized, clip, normal, radius, f.camera.viewport);
}

#ifdef MIRAGE_SURFEL_SPLAT_MERGE
// Subgroup merge (SurfelRenderSettings::subgroupMerge, timed by `bench surfels --merge`): before
// the visibility-buffer access, lanes of a subgroup that hit the same pixel pool their values, and
// only the last lane of each run of equal pixels loads and atomics, with the run's maximum. Meant
// for the coherent order, where consecutive surfels (consecutive lanes) often share a pixel.

// Segmented inclusive max over runs of equal `pixel` in lane order (Hillis-Steele; a lane merges
// lane - offset when both hold the same pixel, so a run's last lane ends with the maximum of the
// whole run; merging a same-pixel lane beyond a gap is harmless, every merged value belongs to
// that pixel). Returns true for the lanes that write: the last of each run. ~0u: no pixel.
// Called in uniform control flow (every lane of the subgroup active).
bool mergeSamePixel(uint pixel, inout uint64_t value) {
  uvec2 acc = unpackUint2x32(value);
  for (uint offset = 1u; offset < gl_SubgroupSize; offset <<= 1) {
    uint otherPixel = subgroupShuffleUp(pixel, offset);
    uvec2 other = subgroupShuffleUp(acc, offset);
    if (gl_SubgroupInvocationID >= offset && otherPixel == pixel && packUint2x32(other) > packUint2x32(acc))
      acc = other;
  }
  value = packUint2x32(acc);
  uint nextPixel = subgroupShuffleDown(pixel, 1u);
  bool last = gl_SubgroupInvocationID + 1u == gl_SubgroupSize || nextPixel != pixel;
  return pixel != ~0u && last;
}

// The subgroup-merge variant of main's loop: the same surfels, discs and atomics, but every lane
// reaches the merge (no early exits), and the pixel holding each projection goes through it.
void splatMerged(SurfelInstanceState s, SurfelRenderFrame f, uvec2 q[MIRAGE_SURFEL_PER_THREAD],
                 uint normals[MIRAGE_SURFEL_PER_THREAD], bool cullBackFaces, uint start, EyeTarget t) {
  SrVisRef vis = SrVisRef(push.visBufferAddress);
  uint width = t.width;
  for (uint j = 0; j < MIRAGE_SURFEL_PER_THREAD; ++j) {
    uint i = start + j * MIRAGE_SURFEL_SPLAT_WORKGROUP;
    uint pixel = ~0u;
    uint64_t value = 0ul;
    vec2 p = vec2(0.0);
    float radius = 0.0;
    vec4 clip = vec4(0.0);
    vec3 quantized = surfelQuantized(q[j]);
    if (i < s.count && !(cullBackFaces && surfelBackFacing(s, quantized, normals[j]))) {
      clip = s.clipFromQuantized * vec4(quantized, 1.0);
      if (clip.w > 0.0 && clip.z <= clip.w && clip.z >= 0.0) {
        p = (clip.xy / clip.w * 0.5 + 0.5) * f.camera.viewport;
        value = (uint64_t(floatBitsToUint(clip.z / clip.w)) << 32) | uint64_t((s.firstId + i) | f.idTag);
        radius = min(s.radiusPixels / clip.w, MIRAGE_SURFEL_MAX_RADIUS_PX);
        if (p.x >= 0.0 && p.y >= 0.0 && p.x < f.camera.viewport.x && p.y < f.camera.viewport.y)
          pixel = uint(p.y) * width + uint(p.x);
      }
    }
    uint64_t merged = value;
    if (mergeSamePixel(pixel, merged)) splatPixel(vis, uvec2(pixel % width, pixel / width), t, merged, s.fade);
    if (value == 0ul || radius < MIRAGE_SURFEL_FAST_RADIUS_PX) continue;
    splatDiscRest(vis, p, radius, discShape(s, f, quantized, clip, radius, i), t, value, s.fade);
  }
}
#endif

// The plain splat: each lane writes its own surfels' pixels (an early exit per surfel).
void splatPlain(SurfelInstanceState s, SurfelRenderFrame f, uvec2 q[MIRAGE_SURFEL_PER_THREAD],
                uint normals[MIRAGE_SURFEL_PER_THREAD], bool cullBackFaces, uint start, EyeTarget t) {
  SrVisRef vis = SrVisRef(push.visBufferAddress);
  for (uint j = 0; j < MIRAGE_SURFEL_PER_THREAD; ++j) {
    uint i = start + j * MIRAGE_SURFEL_SPLAT_WORKGROUP;
    if (i >= s.count) break;
    vec3 quantized = surfelQuantized(q[j]);
    if (cullBackFaces && surfelBackFacing(s, quantized, normals[j])) continue;
    vec4 clip = s.clipFromQuantized * vec4(quantized, 1.0);
    // Behind the eye, nearer than the near plane (reverse-Z: z > w) or beyond the far plane (z < 0).
    if (clip.w <= 0.0 || clip.z > clip.w || clip.z < 0.0) continue;
    vec2 p = (clip.xy / clip.w * 0.5 + 0.5) * f.camera.viewport;
    uint64_t value = (uint64_t(floatBitsToUint(clip.z / clip.w)) << 32) | uint64_t((s.firstId + i) | f.idTag);
    float radius = min(s.radiusPixels / clip.w, MIRAGE_SURFEL_MAX_RADIUS_PX);
    if (p.x < 0.0 || p.y < 0.0 || p.x >= f.camera.viewport.x || p.y >= f.camera.viewport.y) {
      if (radius < MIRAGE_SURFEL_FAST_RADIUS_PX) continue;
    } else {
      // The pixel holding the projection: the whole footprint on the fast path.
      splatPixel(vis, uvec2(p), t, value, s.fade);
      if (radius < MIRAGE_SURFEL_FAST_RADIUS_PX) continue;
    }
    splatDiscRest(vis, p, radius, discShape(s, f, quantized, clip, radius, i), t, value, s.fade);
  }
}

void main() {
  uint batch = gl_WorkGroupID.y * MIRAGE_SURFEL_DISPATCH_X + gl_WorkGroupID.x;
  SrCounterRef counters = SrCounterRef(push.counterAddress);
  if (batch >= counters.c.totalBatches) return; // uniform over the workgroup
  // Two dependent loads to the instance state: the workgroup's prologue is latency it cannot hide.
  uint slot = SrUintRef(push.batchInstanceAddress).v[batch];
  SurfelInstanceState s = SrStateRef(push.stateAddress).states[slot];
  SurfelRenderFrame f = SrFrameRef(push.frameAddress).frame;
  uint firstSurfel = s.firstSurfel;
  SrUvec2Ref positions = SrUvec2Ref(push.positionAddress);
  uint start = (batch - s.firstBatch) * MIRAGE_SURFEL_BATCH + gl_LocalInvocationIndex;

  // All loads first, so each thread has MIRAGE_SURFEL_PER_THREAD requests in flight before the
  // first atomic (bandwidth needs memory-level parallelism; atomics would otherwise serialize them).
  // Back-face culling reads each surfel's attributes too (8 more bytes, coalesced) to skip the
  // surfels facing away; on the H200 that cost more than it saved (docs/surfels.md).
  bool cullBackFaces = kCullBackFaces && s.eyeQuantized.w != 0.0; // uniform over the workgroup (one instance)
  SrUvec2Ref attributes = SrUvec2Ref(push.attributeAddress);
  uvec2 q[MIRAGE_SURFEL_PER_THREAD];
  uint normals[MIRAGE_SURFEL_PER_THREAD];
  for (uint j = 0; j < MIRAGE_SURFEL_PER_THREAD; ++j) {
    uint i = start + j * MIRAGE_SURFEL_SPLAT_WORKGROUP;
    q[j] = i < s.count ? positions.v[firstSurfel + i] : uvec2(0u);
    normals[j] = cullBackFaces && i < s.count ? attributes.v[firstSurfel + i].x : 0u;
  }
  EyeTarget t;
  t.width = uint(f.camera.viewport.x);
  t.height = uint(f.camera.viewport.y);
  t.row = t.width * uint(kEyes);
  // Stereo (docs/render.md, "Stereo"): the surfels loaded once are splatted into both halves. The
  // right eye's state is the left's with its clip x shifted (one shared projection) and its eye
  // moved (back faces, oriented discs); everything else (k, radius, fade) is the one selection's.
  for (uint eye = 0; eye < uint(kEyes); ++eye) {
    SurfelInstanceState se = s;
    t.offsetX = eye * t.width;
    if (eye == 1u) {
      se.clipFromQuantized[3].x += f.stereoEye.w;
      se.eyeQuantized.xyz += s.stereoEyeQuantized.xyz;
    }
#ifdef MIRAGE_SURFEL_SPLAT_MERGE
    // The prefix pass decides per instance (quantStep.w, SurfelMerge): uniform over the workgroup,
    // so the merge's shuffles run in uniform control flow.
    if (s.quantStep.w != 0.0)
      splatMerged(se, f, q, normals, cullBackFaces, start, t);
    else
#endif
      splatPlain(se, f, q, normals, cullBackFaces, start, t);
  }
}

