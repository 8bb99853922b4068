#version 460
// Particle pass 1/3 of a step: every live slot ages and takes one semi-implicit Euler step
// (particleStep, the CPU's formula); a particle that dies frees its slot onto the dead stack (one
// counter atomic per subgroup: particleAppend).
#include "particles_common.glsl"

void main() {
  uint slot = particleIndex();
  UintRef alive = UintRef(push.alive);
  bool dies = false;
  if (slot < push.capacity && alive.v[slot] != 0u) {
    ParticlesRef particles = ParticlesRef(push.particles);
    Particle p = particles.v[slot];
    if (particleStep(p, push.dt)) {
      particles.v[slot] = p;
    } else {
      alive.v[slot] = 0u;
      dies = true;
    }
  }
  uint top = particleAppend(/*live=*/false, dies); // every invocation
  if (dies) UintRef(push.dead).v[top] = slot;
}
