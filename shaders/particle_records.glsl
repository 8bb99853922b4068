// Particle records as the billboard draws and the compute passes (sort, splat) read them: the
// batches' global numbering (ParticleBatchInfo, particleSlot), the eye's camera, a record's
// projected size, the sort key's depth order, the sheet tile of a frame and the sheet's colour
// rule, each written once. Needs buffer references, scalar layout and 64-bit integers;
// shaderio/particle_draw.h, particles.h and view.h included.

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleRecordRef {
  RenderParticle records[];
};
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleBatchRef {
  ParticleBatchInfo batches[];
};
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer ParticleKeyRef { uint64_t keys[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ParticleIndexRef { uint indices[]; };
struct ParticleDrawArgs { // VkDrawIndirectCommand
  uint vertexCount;
  uint instanceCount;
  uint firstVertex;
  uint firstInstance;
};
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer ParticleDrawArgsRef { ParticleDrawArgs args[]; };

// The index of the batch holding global record g: the last whose first record is <= g (batches
// are few).
uint particleBatchIndex(uint64_t batchAddress, uint batchCount, uint g) {
  ParticleBatchRef table = ParticleBatchRef(batchAddress);
  uint b = 0;
  for (uint i = 1; i < batchCount; ++i)
    if (table.batches[i].first <= g) b = i;
  return b;
}

// Global record g: its batch (index and entry of the batch table) and its index in the batch.
struct ParticleSlot {
  uint batch;
  ParticleBatchInfo info;
  uint index;
};
ParticleSlot particleSlot(uint64_t batchAddress, uint batchCount, uint g) {
  uint b = particleBatchIndex(batchAddress, batchCount, g);
  ParticleBatchInfo info = ParticleBatchRef(batchAddress).batches[b];
  return ParticleSlot(b, info, g - info.first);
}
// Whether the slot holds a live particle: below its batch's live count (the instance count of its
// draw arguments at argsAddress) and its room.
bool particleLive(ParticleSlot s, uint64_t argsAddress) {
  return s.index < min(ParticleDrawArgsRef(argsAddress).args[s.batch].instanceCount, s.info.capacity);
}
// Read as two 16-byte words (the records are 16-byte aligned: ParticleBatch): two 128-bit loads,
// where the scalar layout's 4-byte alignment makes a load per member.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ParticleRecordWordsRef { uvec4 v[]; };
RenderParticle particleRecord(ParticleSlot s) {
  ParticleRecordWordsRef w = ParticleRecordWordsRef(s.info.records);
  uvec4 a = w.v[2u * s.index], b = w.v[2u * s.index + 1u];
  return RenderParticle(uintBitsToFloat(a.xyz), uintBitsToFloat(a.w), uintBitsToFloat(b.x), b.y, b.z, b.w);
}

// The eye's camera: the first member of the forward renderer's FrameData and of ClusterFrame.
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer ParticleViewRef { ViewFrame camera; };

// The billboard's edge in pixels at view z `z` from the eye's camera (particleEdgePixels of
// shaderio/particles.h; two members of the ViewFrame read, not all of it): what decides between the
// billboard and the splat.
float particlePixels(ParticleViewRef view, float size, float z) {
  return particleEdgePixels(view.camera.proj[1][1], view.camera.viewport.y, size, z);
}

// The sheet tile of flipbook frame `frame` (wrapped over the tiles.x x tiles.y tiles, row-major
// from the top left): its column and row.
vec2 particleTile(uint frame, uvec2 tiles) {
  frame %= tiles.x * tiles.y;
  return vec2(frame % tiles.x, frame / tiles.x);
}

// View z (negative in front of the eye) as bits whose unsigned order is the float order: the
// sort's key, ascending = farthest first.
uint particleDepthOrder(float z) {
  uint b = floatBitsToUint(z);
  return (b & 0x80000000u) != 0u ? ~b : b | 0x80000000u;
}
float particleDepthFromOrder(uint o) {
  return uintBitsToFloat((o & 0x80000000u) != 0u ? o & 0x7fffffffu : ~o);
}

// The particle's colour (straight alpha) from its record colour and a sheet texel t: the coverage
// is t's luminance (MIRAGE_PARTICLE_ALPHA_FROM_GREY) or t's alpha, times the particle's.
vec4 particleShade(vec4 color, vec4 t, uint flags) {
  if ((flags & MIRAGE_PARTICLE_ALPHA_FROM_GREY) != 0u)
    return vec4(color.rgb, color.a * dot(t.rgb, vec3(0.2126, 0.7152, 0.0722)));
  return color * t;
}
