#version 460
// Sorted mode, keys (particle_sort.cpp): one thread per record slot of every batch; a live
// record's key is its centre's view-depth order bits << 32 | its global index (ascending = back to
// front), an empty slot's ~0 (sorted last).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/particle_draw.h"
#include "mirage/shaderio/particles.h"
#include "mirage/shaderio/view.h"

layout(push_constant, scalar) uniform Push { ParticleSortPush push; };
#include "particle_records.glsl"

layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

void main() {
  uint g = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_DRAW_GROUP +
           gl_LocalInvocationID.x;
  if (g >= push.total) return;
  ParticleSlot slot = particleSlot(push.batchAddress, push.batchCount, g);
  uint64_t key = ~0UL;
  if (particleLive(slot, push.argsAddress)) {
    vec3 position = ParticleRecordRef(slot.info.records).records[slot.index].position;
    float z = (push.view * vec4(position, 1.0)).z;
    key = (uint64_t(particleDepthOrder(z)) << 32) | uint64_t(g);
  }
  ParticleKeyRef(push.keyAddress).keys[g] = key;
}
