#version 460
// Sorted mode, gaps (particle_sort.cpp): one thread per sorted key. A particle's gap is the number
// of sorted blended triangles farther than it (their view z below its own), so it is drawn after
// them and before the rest. Keys ascend, so each gap's particles are one run: the run's first
// thread writes the gap's draw (6 vertices from firstInstance = its position), and the first and
// last threads add -first and last + 1 to its instance count (zeroed before: the sum is the run's
// length). Gaps without particles keep an empty draw.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/particle_draw.h"
#include "mirage/shaderio/particles.h"
#include "mirage/shaderio/view.h"

layout(push_constant, scalar) uniform Push { ParticleSortPush push; };
#include "particle_records.glsl"
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer TriangleDepthRef { float z[]; };

layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

// The gap of sorted key k: the triangles with view z below the particle's (lower bound).
uint gapOf(uint k) {
  float z = particleDepthFromOrder(uint(ParticleKeyRef(push.keyAddress).keys[k] >> 32));
  TriangleDepthRef depths = TriangleDepthRef(push.depthAddress);
  uint lo = 0, hi = push.triangleCount;
  while (lo < hi) {
    uint mid = (lo + hi) / 2;
    if (depths.z[mid] < z) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

bool live(uint k) { return k < push.total && ParticleKeyRef(push.keyAddress).keys[k] != ~0UL; }

void main() {
  uint k = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_DRAW_GROUP +
           gl_LocalInvocationID.x;
  if (!live(k)) return;
  uint gap = gapOf(k);
  ParticleDrawArgsRef draws = ParticleDrawArgsRef(push.gapAddress);
  if (k == 0 || gapOf(k - 1) != gap) { // the run's first
    draws.args[gap].vertexCount = 6;
    draws.args[gap].firstInstance = k;
    atomicAdd(draws.args[gap].instanceCount, uint(-int(k)));
  }
  if (!live(k + 1) || gapOf(k + 1) != gap) atomicAdd(draws.args[gap].instanceCount, k + 1); // the run's last
}
