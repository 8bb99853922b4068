#version 460
// The render records of every live particle (particleRender), compacted into push.render in any
// order; counters.live (zeroed before) ends as their count, the instance count of an indirect draw.
#include "particles_common.glsl"

void main() {
  uint slot = particleIndex();
  if (slot >= push.capacity || UintRef(push.alive).v[slot] == 0u) return;
  uint index = atomicAdd(CountersRef(push.counters).c.live, 1u);
  RenderRef(push.render).v[index] = particleRender(ParamsRef(push.params).p, ParticlesRef(push.particles).v[slot]);
}
