#version 460
// The marking rasters' depth tiles (MIRAGE_ATLAS_DEPTH_TILE, shaderio/atlas_shading.h): one
// workgroup per tile of one camera's 64-bit visibility buffer, the smallest nearest depth of its
// pixels (reverse-Z: the farthest) stored after the camera's pixels.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/atlas_shading.h"

layout(local_size_x = MIRAGE_ATLAS_DEPTH_TILE, local_size_y = MIRAGE_ATLAS_DEPTH_TILE) in;
layout(push_constant, scalar) uniform Push { AtlasDepthTilesPush push; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer PixelsRef { uint64_t pixels[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer TilesRef { uint tiles[]; };

shared uint tileMin;

void main() {
  if (gl_LocalInvocationIndex == 0) tileMin = 0xffffffffu;
  barrier();
  uvec2 p = gl_GlobalInvocationID.xy;
  // Positive float bits order as the floats: the smallest bits are the farthest depth.
  if (p.x < push.width && p.y < push.height)
    atomicMin(tileMin, uint(PixelsRef(push.visBufferAddress).pixels[p.y * push.width + p.x] >> 32));
  barrier();
  if (gl_LocalInvocationIndex == 0) {
    uint64_t tilesAddress = push.visBufferAddress + uint64_t(push.width) * push.height * 8u;
    TilesRef(tilesAddress).tiles[gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x] = tileMin;
  }
}
