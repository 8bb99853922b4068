// The shared atlas layout, mirrored from include/mirage/shaderio/atlas.h (the source: change it
// there first, then here). A patch of 1-3 triangles lies in a block 2^log2 texels high, as wide
// (1-2 triangles) or twice as wide (3 triangles); its vertex slots a..e sit on texel centres of the
// block's corners, so bilinear taps never leave the block.
export const ATLAS_MIN_BLOCK_LOG2 = 1;
export const ATLAS_MAX_BLOCK_LOG2 = 7;
export const PATCH_A = 0, PATCH_B = 1, PATCH_C = 2, PATCH_D = 3, PATCH_E = 4;
// Protocol: a patch that did not fit in the atlas (drawn with its colour message).
export const COLOUR_ONLY_BLOCK = 0xff;

export function atlasBlockWidth(triangleCount, blockLog2) { return (triangleCount === 3 ? 2 : 1) << blockLog2; }

// Texel position (texel centres at .5) of vertex slot v inside a block of height 2^blockLog2.
export function atlasCornerTexel(v, blockLog2) {
  const h = 1 << blockLog2;
  const far = h - 0.5;
  if (v === PATCH_B) return [ far, 0.5 ];
  if (v === PATCH_C) return [ 0.5, far ];
  if (v === PATCH_D) return [ far, far ];
  if (v === PATCH_E) return [ 2 * h - 0.5, 0.5 ];
  return [ 0.5, 0.5 ];
}

// Vertex slots of triangle t (0..2): t0 = (a, b, c), t1 = (c, b, d), t2 = (b, e, d).
export function atlasTriangleVertex(t, corner) {
  const packed = t === 0 ? 0x210 : t === 1 ? 0x312 : 0x341;
  return (packed >> (4 * corner)) & 0xf;
}

// A streamed particle look's block is 2h x h: level 0 (h texels a side) at its left, its mips side
// by side right of it; the x offset of level k (shaderio/atlas.h atlasParticleLevelOffset).
export function atlasParticleLevelOffset(level, blockLog2) {
  const h = 1 << blockLog2;
  return level === 0 ? 0 : 2 * h - (h >> (level - 1));
}

// The triangle of the patch that texel (i, j) of its block is shaded as.
export function atlasTexelTriangle(i, j, triangleCount, blockLog2) {
  const h = 1 << blockLog2;
  if (triangleCount === 3 && i >= h) return 2;
  if (i + j <= h - 1 || triangleCount === 1) return 0;
  return 1;
}
