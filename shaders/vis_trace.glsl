// Shared by the ray backend's shaders (vis_trace.rgen/.rchit/.rmiss/.rahit): extensions, the
// push constants and the payload.
#extension GL_EXT_ray_tracing : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/rays.h"

layout(push_constant, scalar) uniform Push { RtTracePush push; };

struct Payload {
  uint triangle; // closest opaque hit (global ID) or MIRAGE_RT_NO_HIT
  float t;
  uint count; // see-through candidates below
  uint ids[MIRAGE_RT_MAX_CANDIDATES];
  float ts[MIRAGE_RT_MAX_CANDIDATES];
};

// The bit sets use 32-bit words: the same bytes as TriangleSet's 64-bit words (little endian).
bool testBit(uint64_t set, uint id) { return ((RtU32Ref(set).v[id >> 5] >> (id & 31u)) & 1u) != 0u; }

// The slot of the current hit (hit shaders define MIRAGE_RT_HIT_STAGE): the TLAS instance
// (instanced scenes, one geometry per BLAS) or the BLAS geometry (flattened scenes, one instance).
#ifdef MIRAGE_RT_HIT_STAGE
uint hitSlot() { return uint(gl_InstanceID) + uint(gl_GeometryIndexEXT); }
#endif
