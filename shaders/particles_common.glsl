// Shared by the particle passes: the buffers behind ParticlePush's addresses.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "mirage/shaderio/particles.h"

layout(local_size_x = MIRAGE_PARTICLE_GROUP) in;
layout(push_constant, scalar) uniform Push { ParticlePush push; };

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParamsRef { ParticleParams p; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ParticlesRef { Particle v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer UintRef { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer CountersRef { ParticleCounters c; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer RenderRef { RenderParticle v[]; };

// The invocation's index over a dispatch of up to 65535 x N groups (cmdPass splits large counts
// into rows: 65535 is the smallest maxComputeWorkGroupCount[0] Vulkan allows).
uint particleIndex() {
  return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_GROUP + gl_LocalInvocationID.x;
}

// A slot of a buffer appended to for each invocation with `take` (the render records: counter
// `live`; else the dead stack: `deadCount`), one counter atomic per subgroup, its lanes taking
// consecutive slots (their writes coalesce): a pool's particles appending one by one would
// serialize millions of atomics on one address. Call in subgroup-uniform control flow; the result
// is meaningful where `take`.
uint particleAppend(bool live, bool take) {
  uvec4 ballot = subgroupBallot(take);
  uint count = subgroupBallotBitCount(ballot), base = 0u;
  if (count != 0u) { // uniform over the subgroup
    CountersRef counters = CountersRef(push.counters);
    if (subgroupElect()) base = live ? atomicAdd(counters.c.live, count) : atomicAdd(counters.c.deadCount, count);
    base = subgroupBroadcastFirst(base); // the elected invocation is the first active one
  }
  return base + subgroupBallotExclusiveBitCount(ballot);
}
