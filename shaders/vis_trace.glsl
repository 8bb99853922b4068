// Shared by the ray-tracing pipeline's shaders (vis_trace.rgen/.rchit/.rmiss/.rahit): the
// ray-tracing extension on top of vis_trace_common.glsl.
#extension GL_EXT_ray_tracing : require
#include "vis_trace_common.glsl"

// The slot of the current hit (hit shaders define MIRAGE_RT_HIT_STAGE): the TLAS instance
// (instanced scenes, one geometry per BLAS) or the BLAS geometry (flattened scenes, one instance).
#ifdef MIRAGE_RT_HIT_STAGE
uint hitSlot() { return uint(gl_InstanceID) + uint(gl_GeometryIndexEXT); }
#endif
