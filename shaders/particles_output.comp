#version 460
// The render records of every live particle (particleRender), compacted into push.render in any
// order; counters.live (zeroed before) ends as their count, the instance count of an indirect draw.
// One counter atomic per workgroup (particleAppend).
#include "particles_common.glsl"

void main() {
  uint slot = particleIndex();
  bool live = slot < push.capacity && UintRef(push.alive).v[min(slot, push.capacity - 1u)] != 0u;
  uint index = particleAppend(/*live=*/true, live); // every invocation
  if (live) renderStore(index, particleRender(ParamsRef(push.params).p, particleLoad(slot)));
}
