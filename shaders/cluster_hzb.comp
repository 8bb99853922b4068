#version 460
// HZB build in two dispatches: the farthest (smallest reverse-Z) depth per texel, so a texel of
// level L bounds the pixels [2^L x, 2^L (x + 1)) x [2^L y, 2^L (y + 1)). Level 0 would only copy
// the visibility depth and is not stored: level 1 reads it directly (the 64-bit buffer's high word,
// or the hardware backends' depth attachment). Background is depth 0: nothing behind it is culled.
// push.rasterList 0: one 16x16 workgroup per 16x16 tile of level 1 builds levels 1..5 of its tile
// in shared memory; 1: one workgroup builds every level from 6 on (level 5 is 1/32 of the screen).
// Odd sizes: a texel's missing children count as "nothing" (1.0 for a min), the same as clamping
// to the edge texel.
#include "cluster_common.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) coherent buffer CoherentFloatRef { float data[]; };

layout(set = 0, binding = 3) uniform sampler2D depthImage;
layout(local_size_x = 16, local_size_y = 16) in;

#define TILE_LEVELS 5 // levels 1..5 per 16x16 tile

shared float tile[16][16];

// Level 0 is the visibility target: both eyes side by side in stereo (pushed: the left eye's frame).
ivec2 levelSize(ClusterFrame f, uint level) {
  return (ivec2(targetRowPixels(f), f.camera.viewport.y) + (1 << level) - 1) >> level;
}

float sourceDepth(ClusterFrame f, ivec2 q) {
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) != 0)
    return uintBitsToFloat(uint(VisBufferRef(push.visBufferAddress).pixels[q.y * int(targetRowPixels(f)) + q.x] >> 32));
  return texelFetch(depthImage, q, 0).r;
}

void buildTile(ClusterFrame f) {
  FloatRef hzb = FloatRef(f.hzbAddress);
  ivec2 local = ivec2(gl_LocalInvocationID.xy);
  // Level 1: 2x2 source pixels per thread.
  ivec2 p = ivec2(gl_WorkGroupID.xy) * 16 + local;
  ivec2 size = levelSize(f, 1);
  float depth = 1.0;
  if (all(lessThan(p, size))) {
    ivec2 last = levelSize(f, 0) - 1;
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) depth = min(depth, sourceDepth(f, min(p * 2 + ivec2(dx, dy), last)));
    hzb.data[f.hzbOffset[1] + p.y * size.x + p.x] = depth;
  }
  tile[local.y][local.x] = depth;
  // Levels 2..5 from shared memory, a quarter of the threads fewer each time.
  for (int level = 2; level <= TILE_LEVELS && level < int(f.hzbLevels); ++level) {
    barrier();
    int n = 16 >> (level - 1); // texels per tile side at this level
    bool inTile = all(lessThan(local, ivec2(n)));
    if (inTile) {
      ivec2 c = local * 2;
      depth = min(min(tile[c.y][c.x], tile[c.y][c.x + 1]), min(tile[c.y + 1][c.x], tile[c.y + 1][c.x + 1]));
    }
    barrier();
    if (inTile) {
      tile[local.y][local.x] = depth;
      ivec2 q = ivec2(gl_WorkGroupID.xy) * n + local;
      ivec2 s = levelSize(f, uint(level));
      if (all(lessThan(q, s))) hzb.data[f.hzbOffset[level] + q.y * s.x + q.x] = depth;
    }
  }
}

void buildRest(ClusterFrame f) {
  CoherentFloatRef hzb = CoherentFloatRef(f.hzbAddress);
  uint thread = gl_LocalInvocationIndex;
  for (uint level = TILE_LEVELS + 1; level < f.hzbLevels; ++level) {
    ivec2 size = levelSize(f, level), below = levelSize(f, level - 1);
    for (uint i = thread; i < uint(size.x * size.y); i += 256) {
      ivec2 p = ivec2(int(i) % size.x, int(i) / size.x);
      float depth = 1.0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          ivec2 q = min(p * 2 + ivec2(dx, dy), below - 1);
          depth = min(depth, hzb.data[f.hzbOffset[level - 1] + q.y * below.x + q.x]);
        }
      hzb.data[f.hzbOffset[level] + p.y * size.x + p.x] = depth;
    }
    memoryBarrierBuffer();
    barrier();
  }
}

void main() {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if (push.rasterList == 0)
    buildTile(f);
  else
    buildRest(f);
}
