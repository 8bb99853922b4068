// The splat's accumulators with 64-bit integer atomics, where float atomic adds are missing: each
// sum in fixed point of MIRAGE_SPLAT_FIXED_BITS fraction bits (splatUnits). 2^32 units per unit: a
// weight of 10^-2 x an alpha of 10^-3 still spans some 43 000 units, and 2^31 units of headroom
// hold a million full-weight layers.
#extension GL_EXT_shader_atomic_int64 : require
#include "particle_splat.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 8) buffer SplatFixedRef { uint64_t v[]; };

void splatAddUnits(uint index, uint64_t units) {
  if (units != 0UL) atomicAdd(SplatFixedRef(push.accumAddress).v[index], units);
}
void splatStoreUnits(uint index, uint64_t units) { SplatFixedRef(push.accumAddress).v[index] = units; }
void splatAdd(uint index, float value) { splatAddUnits(index, splatUnits(value)); }
void splatStore(uint index, float value) { splatStoreUnits(index, splatUnits(value)); }
