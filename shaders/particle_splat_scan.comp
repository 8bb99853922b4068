#version 460
// The binned splat's scan (docs/particles.md, "Splat"), one workgroup: per tile its first entry
// (the exclusive prefix sum of the counts) and its first chunk (of ceil(count /
// MIRAGE_SPLAT_CHUNK) chunks each), the counts zeroed as the scatter's cursors, and the tile
// pass's indirect dispatch (its chunks in rows of at most 65535 workgroups).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/particle_draw.h"

layout(push_constant, scalar) uniform Push { ParticleSplatPush push; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SplatBinsRef { uint v[]; };

#define GROUP 1024 // the most a workgroup may hold: the fewest tiles per invocation (each reads its run in turn)
layout(local_size_x = GROUP) in;
shared uvec2 partial[GROUP]; // (entries, chunks) of each invocation's run of tiles, then their prefix

uvec2 tileSizes(uint count) { return uvec2(count, (count + MIRAGE_SPLAT_CHUNK - 1u) / MIRAGE_SPLAT_CHUNK); }

void main() {
  SplatBinsRef bins = SplatBinsRef(push.binAddress);
  uint tiles = push.eyes * push.tilesX * push.tilesY;
  uint counts = MIRAGE_SPLAT_BIN_HEADER, starts = counts + tiles, chunks = starts + tiles + 1u;
  uint i = gl_LocalInvocationID.x;
  uint per = (tiles + GROUP - 1u) / GROUP, begin = min(i * per, tiles), end = min(begin + per, tiles);
  uvec2 own = uvec2(0u);
  for (uint t = begin; t < end; ++t) own += tileSizes(bins.v[counts + t]);
  partial[i] = own;
  barrier();
  for (uint offset = 1u; offset < GROUP; offset <<= 1u) { // inclusive scan (Hillis and Steele)
    uvec2 before = i >= offset ? partial[i - offset] : uvec2(0u);
    barrier();
    partial[i] += before;
    barrier();
  }
  uvec2 at = partial[i] - own;
  for (uint t = begin; t < end; ++t) {
    uvec2 sizes = tileSizes(bins.v[counts + t]);
    bins.v[starts + t] = at.x;
    bins.v[chunks + t] = at.y;
    bins.v[counts + t] = 0u;
    at += sizes;
  }
  if (i == GROUP - 1u) {
    uvec2 total = partial[i];
    bins.v[starts + tiles] = total.x;
    bins.v[chunks + tiles] = total.y;
    bins.v[0] = min(total.y, 65535u); // VkDispatchIndirectCommand
    bins.v[1] = (total.y + 65534u) / 65535u;
    bins.v[2] = 1u;
    bins.v[MIRAGE_SPLAT_BIN_CHUNKS] = total.y;
    bins.v[MIRAGE_SPLAT_BIN_ENTRIES] = total.x;
  }
}
