// The splat's accumulators as floats, added with float atomic adds (shaderBufferFloat32AtomicAdd).
#extension GL_EXT_shader_atomic_float : require
#include "particle_splat.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer SplatFloatRef { float v[]; };

void splatAdd(uint index, float value) { atomicAdd(SplatFloatRef(push.accumAddress).v[index], value); }
void splatStore(uint index, float value) { SplatFloatRef(push.accumAddress).v[index] = value; }
