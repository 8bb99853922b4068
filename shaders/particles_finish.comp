#version 460
// Particle pass 3/3 of a step (one invocation): pop the emitted slots and advance the spawn index.
#include "particles_common.glsl"

void main() {
  if (particleIndex() != 0u) return;
  CountersRef counters = CountersRef(push.counters);
  counters.c.deadCount -= counters.c.emitted;
  counters.c.nextId += counters.c.emitted;
  counters.c.emitted = 0u;
}
