// Particle records as the billboard draws and the compute passes (sort, splat) read them: the
// batches' global numbering (ParticleBatchInfo), a record's projected size, the sort key's depth
// order and the sheet's colour rule, each written once. Needs buffer references, scalar layout and
// 64-bit integers; shaderio/particle_draw.h, particles.h and view.h included.

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

// The billboard's edge in pixels at view z `z` (perspective: |proj[1][1]| / -z scales view units
// to NDC; proj11 and viewportHeight from the eye's ViewFrame): what decides between the billboard
// and the splat.
float particlePixels(float proj11, float viewportHeight, float size, float z) {
  return size * abs(proj11) * 0.5 * viewportHeight / max(-z, 1e-6);
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
