#version 460
// Particle pass 2/3 of a step: the step's emission (push.emit, the CPU's emitRequest) takes slots
// from the top of the dead stack; spawn index nextId + i keys each particle's random numbers, so
// particle i is the CPU's particle of the same index. The finish pass pops the stack. With
// push.writeRender, each spawned particle's render record is appended (after the update's).
#include "particles_common.glsl"

void main() {
  uint i = particleIndex();
  CountersRef counters = CountersRef(push.counters);
  uint n = min(push.emit, counters.c.deadCount);
  if (i == 0u) counters.c.emitted = n;
  Particle p;
  if (i < n) {
    uint slot = UintRef(push.dead).v[counters.c.deadCount - 1u - i];
    p = particleSpawn(ParamsRef(push.params).p, counters.c.nextId + i);
    particleStore(slot, p);
    UintRef(push.alive).v[slot] = 1u;
  }
  if (push.writeRender == 0u) return; // uniform
  uint index = particleAppend(/*live=*/true, i < n);
  if (i < n) renderStore(index, particleRender(ParamsRef(push.params).p, p));
}
