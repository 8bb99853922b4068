#version 460
// Particle pass 2/3 of a step: the step's emission (push.emit, the CPU's emitRequest) takes slots
// from the top of the dead stack; spawn index nextId + i keys each particle's random numbers, so
// particle i is the CPU's particle of the same index. The finish pass pops the stack.
#include "particles_common.glsl"

void main() {
  uint i = particleIndex();
  CountersRef counters = CountersRef(push.counters);
  uint n = min(push.emit, counters.c.deadCount);
  if (i == 0u) counters.c.emitted = n;
  if (i >= n) return;
  uint slot = UintRef(push.dead).v[counters.c.deadCount - 1u - i];
  ParticlesRef(push.particles).v[slot] = particleSpawn(ParamsRef(push.params).p, counters.c.nextId + i);
  UintRef(push.alive).v[slot] = 1u;
}
