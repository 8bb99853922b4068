// Shared declarations of forward.vert and forward.frag.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/forward.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer FrameRef { FrameData frame; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer InstanceRef { GpuInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MaterialRef { GpuMaterial materials[]; };

layout(push_constant, scalar) uniform Push { ForwardPush push; };
