// Shared by the particle passes: the buffers behind ParticlePush's addresses.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "mirage/shaderio/particles.h"

layout(local_size_x = MIRAGE_PARTICLE_GROUP) in;
layout(push_constant, scalar) uniform Push { ParticlePush push; };

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParamsRef { ParticleParams p; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer UintRef { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer CountersRef { ParticleCounters c; };
// Particle[] and RenderParticle[] as 16-byte words (48 and 32 bytes a record): one 128-bit access
// per word, where the scalar layout's 4-byte alignment makes a load or store per member.
layout(buffer_reference, std430, buffer_reference_align = 16) buffer WordsRef { uvec4 v[]; };

// The invocation's index over a dispatch of up to 65535 x N groups (cmdPass splits large counts
// into rows: 65535 is the smallest maxComputeWorkGroupCount[0] Vulkan allows).
uint particleIndex() {
  return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_GROUP + gl_LocalInvocationID.x;
}

Particle particleLoad(uint slot) {
  WordsRef w = WordsRef(push.particles);
  uvec4 a = w.v[3u * slot], b = w.v[3u * slot + 1u], c = w.v[3u * slot + 2u];
  return Particle(uintBitsToFloat(a.xyz), uintBitsToFloat(a.w), uintBitsToFloat(b.xyz), uintBitsToFloat(b.w),
                  uintBitsToFloat(c.xyz), c.w);
}
// The words a step changes (position, age, velocity; lifetime rides along): 32 of the 48 bytes.
void particleStoreMotion(uint slot, Particle p) {
  WordsRef w = WordsRef(push.particles);
  w.v[3u * slot] = uvec4(floatBitsToUint(p.position), floatBitsToUint(p.age));
  w.v[3u * slot + 1u] = uvec4(floatBitsToUint(p.velocity), floatBitsToUint(p.lifetime));
}
void particleStore(uint slot, Particle p) {
  particleStoreMotion(slot, p);
  WordsRef(push.particles).v[3u * slot + 2u] = uvec4(floatBitsToUint(p.acceleration), p.id);
}
void renderStore(uint index, RenderParticle r) {
  WordsRef w = WordsRef(push.render);
  w.v[2u * index] = uvec4(floatBitsToUint(r.position), floatBitsToUint(r.size));
  w.v[2u * index + 1u] = uvec4(floatBitsToUint(r.rotation), r.color, r.frame, r.id);
}

// Slots of the dead stack (each invocation with `dead`, counter deadCount) and of the render records
// (each with `live`, counter live), one counter atomic per workgroup and counter: the subgroups'
// counts gather in shared memory (a ballot and one shared atomic each), one invocation adds the
// workgroup's totals, and each lane takes its subgroup's base + its rank (consecutive slots: the
// writes coalesce). A pool's particles appending one by one, or even per subgroup, would serialize
// millions (hundreds of thousands) of atomics on one address. The update pass takes both at once.
// Call in workgroup-uniform control flow (it has barriers); each result is meaningful where its
// flag is set. Returns (dead stack slot, record slot).
shared uint appendCounts[2], appendBases[2];
uvec2 particleAppendBoth(bool dead, bool live) {
  if (gl_LocalInvocationIndex == 0u) appendCounts[0] = appendCounts[1] = 0u;
  barrier();
  uvec4 deadBallot = subgroupBallot(dead), liveBallot = subgroupBallot(live);
  uint deadCount = subgroupBallotBitCount(deadBallot), liveCount = subgroupBallotBitCount(liveBallot);
  uint deadBase = 0u, liveBase = 0u;
  if (subgroupElect()) {
    if (deadCount != 0u) deadBase = atomicAdd(appendCounts[0], deadCount);
    if (liveCount != 0u) liveBase = atomicAdd(appendCounts[1], liveCount);
  }
  deadBase = subgroupBroadcastFirst(deadBase); // the elected invocation is the first active one
  liveBase = subgroupBroadcastFirst(liveBase);
  barrier();
  if (gl_LocalInvocationIndex == 0u) {
    CountersRef counters = CountersRef(push.counters);
    if (appendCounts[0] != 0u) appendBases[0] = atomicAdd(counters.c.deadCount, appendCounts[0]);
    if (appendCounts[1] != 0u) appendBases[1] = atomicAdd(counters.c.live, appendCounts[1]);
  }
  barrier();
  return uvec2(appendBases[0] + deadBase + subgroupBallotExclusiveBitCount(deadBallot),
               appendBases[1] + liveBase + subgroupBallotExclusiveBitCount(liveBallot));
}

// One of them: a record slot (`live`) or a dead stack slot, for each invocation with `take`.
uint particleAppend(bool live, bool take) {
  uvec2 at = particleAppendBoth(!live && take, live && take);
  return live ? at.y : at.x;
}
