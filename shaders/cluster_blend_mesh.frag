#version 460
// Hardware blend raster, mesh shaders: as cluster_blend.frag, the id arriving per primitive.
#extension GL_EXT_mesh_shader : require
#include "cluster_common.glsl"
#include "cluster_oit.glsl"

layout(location = 0) perprimitiveEXT flat in uvec2 inId;

#include "cluster_blend_frag.glsl"
