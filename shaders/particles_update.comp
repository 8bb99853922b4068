#version 460
// Particle pass 1/3 of a step: every live slot ages and takes one semi-implicit Euler step
// (particleStep, the CPU's formula); a particle that dies frees its slot onto the dead stack (one
// counter atomic per workgroup: particleAppend). With push.writeRender, a survivor's render record
// is appended too (particleRender of its new state, as the output pass would write it; both
// appends in one: particleAppendBoth), so a frame reads each particle once.
#include "particles_common.glsl"

void main() {
  uint slot = particleIndex();
  UintRef alive = UintRef(push.alive);
  bool dies = false, lives = false;
  Particle p;
  if (slot < push.capacity && alive.v[slot] != 0u) {
    p = particleLoad(slot);
    if (particleStep(p, push.dt)) {
      particleStoreMotion(slot, p);
      lives = true;
    } else {
      alive.v[slot] = 0u;
      dies = true;
    }
  }
  bool record = lives && push.writeRender != 0u;
  uvec2 at = particleAppendBoth(dies, record); // every invocation
  if (dies) UintRef(push.dead).v[at.x] = slot;
  if (record) renderStore(at.y, particleRender(ParamsRef(push.params).p, p));
}
