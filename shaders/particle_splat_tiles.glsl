// The binned splat's tile pass (particle_splat.glsl; after the scatter): one workgroup per chunk
// of a tile's list (indirect, the scan's rows), an invocation per tile pixel. The tile's opaque
// depth is read once into shared memory; each invocation takes entries of the chunk (in list
// order: the footprint, depth and colour the scatter packed, the sums the atomic splat would add),
// and adds their pixels' five sums to shared sums, in the fixed point of the fixed accumulators (2^-32
// units) as two 32-bit words with the carry carried by hand: 32-bit integer adds are the shared
// atomics the hardware has (float and 64-bit ones are compare-and-swap loops, 4.7 and 7.4 times
// slower on an H100), and integer sums are exact in any order. Then each pixel's sums are written
// once: stored where this workgroup is the tile's only writer (a list of one chunk, wholly within
// the room), else added (global atomics). Included after a sums file.
#define SPLAT_TILE_PIXELS (MIRAGE_SPLAT_TILE * MIRAGE_SPLAT_TILE)
layout(local_size_x = SPLAT_TILE_PIXELS) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SplatBinsRef { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer SplatEntryRef { uvec4 v[]; };

shared uint sumsLow[SPLAT_TILE_PIXELS * MIRAGE_SPLAT_CHANNELS];  // pixel-major, the units' low words
shared uint sumsHigh[SPLAT_TILE_PIXELS * MIRAGE_SPLAT_CHANNELS]; // and high words
shared float depths[SPLAT_TILE_PIXELS];

// Shared sum `index` += value, in units.
void sharedAdd(uint index, float value) {
  uvec2 words = unpackUint2x32(splatUnits(value));
  uint before = atomicAdd(sumsLow[index], words.x);
  if (before + words.x < before) ++words.y; // the low word wrapped
  if (words.y != 0u) atomicAdd(sumsHigh[index], words.y);
}

void main() {
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  uint tiles = push.eyes * push.tilesX * push.tilesY;
  uint starts = MIRAGE_SPLAT_BIN_HEADER + tiles, chunks = starts + tiles + 1u;
  uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  if (group >= bins.v[MIRAGE_SPLAT_BIN_CHUNKS]) return; // the last row's spare workgroups
  // The tile: the last whose first chunk is at or before this one.
  uint lo = 0u, hi = tiles;
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (bins.v[chunks + mid] <= group) lo = mid;
    else hi = mid;
  }
  uint tile = lo;
  uint tileBegin = bins.v[starts + tile], tileEnd = bins.v[starts + tile + 1u];
  uint begin = tileBegin + (group - bins.v[chunks + tile]) * MIRAGE_SPLAT_CHUNK;
  uint end = min(min(begin + MIRAGE_SPLAT_CHUNK, tileEnd), push.entryRoom);
  bool alone = tileEnd - tileBegin <= MIRAGE_SPLAT_CHUNK && tileEnd <= push.entryRoom;

  uint eye = tile / (push.tilesX * push.tilesY), inEye = tile % (push.tilesX * push.tilesY);
  ivec2 origin = ivec2(inEye % push.tilesX, inEye / push.tilesX) * MIRAGE_SPLAT_TILE;
  ivec2 last = min(origin + MIRAGE_SPLAT_TILE - 1, ivec2(push.eyeWidth, push.height) - 1);
  uint i = gl_LocalInvocationID.x;
  ivec2 pixel = origin + ivec2(i % MIRAGE_SPLAT_TILE, i / MIRAGE_SPLAT_TILE);
  bool inside = all(lessThanEqual(pixel, last));
  uint px = uint(pixel.x) + eye * push.eyeWidth;
  // Outside the target nothing passes (reverse-Z: the footprint's depth must be GREATER).
  depths[i] = inside ? texelFetch(opaqueDepth, ivec2(px, pixel.y), 0).r : 2.0;
  for (uint c = 0u; c < MIRAGE_SPLAT_CHANNELS; ++c) {
    sumsLow[i * MIRAGE_SPLAT_CHANNELS + c] = 0u;
    sumsHigh[i * MIRAGE_SPLAT_CHANNELS + c] = 0u;
  }
  barrier();

  SplatEntryRef entries = SplatEntryRef(push.entryAddress);
  for (uint k = begin + i; k < end; k += SPLAT_TILE_PIXELS) {
    SplatFootprint f;
    vec4 color;
    splatUnpack(entries.v[k], eye, origin, f, color);
    vec2 flo = f.lo, fhi = f.hi;
    float depth = f.depth, weight = f.weight;
    ivec2 first = max(f.first, origin), to = min(f.last, last);
    for (int y = first.y; y <= to.y; ++y)
      for (int x = first.x; x <= to.x; ++x) {
        float a = splatCoverage(flo, fhi, color.a, x, y);
        if (!(a > 0.0)) continue;
        uint p = uint(y - origin.y) * MIRAGE_SPLAT_TILE + uint(x - origin.x);
        if (depth <= depths[p]) continue; // behind the opaque surface
        float logReveal;
        vec4 add = splatSums(color.rgb, a, weight, logReveal);
        uint base = p * MIRAGE_SPLAT_CHANNELS;
        sharedAdd(base + 0u, add.x);
        sharedAdd(base + 1u, add.y);
        sharedAdd(base + 2u, add.z);
        sharedAdd(base + 3u, add.w);
        sharedAdd(base + 4u, logReveal);
      }
  }
  barrier();

  uint own = i * MIRAGE_SPLAT_CHANNELS;
  if (!inside || (sumsLow[own + 4u] | sumsHigh[own + 4u]) == 0u) return; // nothing splatted here
  uint base = splatBase(px, uint(pixel.y));
  for (uint c = 0u; c < MIRAGE_SPLAT_CHANNELS; ++c) {
    uint64_t units = packUint2x32(uvec2(sumsLow[own + c], sumsHigh[own + c]));
    if (alone) splatStoreUnits(base + c, units);
    else splatAddUnits(base + c, units);
  }
}
