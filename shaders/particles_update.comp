#version 460
// Particle pass 1/3 of a step: every live slot ages and takes one semi-implicit Euler step
// (particleStep, the CPU's formula); a particle that dies frees its slot onto the dead stack.
#include "particles_common.glsl"

void main() {
  uint slot = particleIndex();
  if (slot >= push.capacity) return;
  UintRef alive = UintRef(push.alive);
  if (alive.v[slot] == 0u) return;
  ParticlesRef particles = ParticlesRef(push.particles);
  Particle p = particles.v[slot];
  if (particleStep(p, push.dt)) {
    particles.v[slot] = p;
    return;
  }
  alive.v[slot] = 0u;
  CountersRef counters = CountersRef(push.counters);
  UintRef(push.dead).v[atomicAdd(counters.c.deadCount, 1u)] = slot;
}
