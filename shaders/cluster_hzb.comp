#version 460
// One HZB level (push.rasterList = level >= 1), one thread per texel: the farthest (smallest
// reverse-Z) depth of the 2x2 texels under it, so a texel of level L bounds the pixels
// [2^L x, 2^L (x + 1)) x [2^L y, 2^L (y + 1)). Level 1 reads the visibility depth itself (the 64-bit
// buffer's high word, or the hardware backends' depth attachment): level 0 would only copy it.
// Background is depth 0: nothing behind it is ever culled.
#include "cluster_common.glsl"

layout(set = 0, binding = 3) uniform sampler2D depthImage;
layout(local_size_x = 8, local_size_y = 8) in;

ivec2 levelSize(ClusterFrame f, uint level) { return (ivec2(f.viewport) + (1 << level) - 1) >> level; }

float sourceDepth(ClusterFrame f, ivec2 q) {
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) != 0)
    return uintBitsToFloat(uint(VisBufferRef(push.visBufferAddress).pixels[q.y * int(f.viewport.x) + q.x] >> 32));
  return texelFetch(depthImage, q, 0).r;
}

void main() {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  uint level = push.rasterList;
  ivec2 size = levelSize(f, level);
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= size.x || p.y >= size.y) return;
  FloatRef hzb = FloatRef(f.hzbAddress);
  ivec2 below = levelSize(f, level - 1);
  uint base = f.hzbOffset[level - 1];
  float depth = 1.0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      ivec2 q = min(p * 2 + ivec2(dx, dy), below - 1); // odd sizes: the edge texel counts twice
      depth = min(depth, level == 1 ? sourceDepth(f, q) : hzb.data[base + q.y * below.x + q.x]);
    }
  hzb.data[f.hzbOffset[level] + p.y * size.x + p.x] = depth;
}
