// The splat's accumulators as floats, added with float atomic adds (shaderBufferFloat32AtomicAdd).
#extension GL_EXT_shader_atomic_float : require
#include "particle_splat.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SplatFloatRef { float v[]; };

void splatAdd(uint index, float value) { atomicAdd(SplatFloatRef(push.accumAddress).v[index], value); }
void splatStore(uint index, float value) { SplatFloatRef(push.accumAddress).v[index] = value; }
float splatFromUnits(uint64_t units) { return float(units) * exp2(-float(MIRAGE_SPLAT_FIXED_BITS)); }
void splatAddUnits(uint index, uint64_t units) {
  if (units != 0UL) splatAdd(index, splatFromUnits(units));
}
void splatStoreUnits(uint index, uint64_t units) { splatStore(index, splatFromUnits(units)); }
