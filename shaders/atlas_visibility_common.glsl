// Shared declarations of the atlas visibility passes (atlas_visibility.vert and its fragment shaders).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/forward.h"
#include "mirage/shaderio/atlas_shading.h"

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer InstanceRef { GpuInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MaterialRef { GpuMaterial materials[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer UintRef { uint values[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer FlagRef { uint flags[]; };

layout(push_constant, scalar) uniform Push { AtlasVisibilityPush push; };
