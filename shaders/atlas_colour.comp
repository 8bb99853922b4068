#version 460
// Colour-only patches (blocks that did not fit): one RGBA8 colour each, the shading at the
// patch's centroid. The texture footprint is the triangle itself (one step = one edge), so
// textures are read at the mip that averages them over the triangle.
#include "atlas_surface.glsl"

layout(local_size_x = MIRAGE_ATLAS_COLOUR_GROUP) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SampleRef { AtlasColourSample samples[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OutputRef { uint colors[]; };
layout(push_constant, scalar) uniform Push { AtlasColourPush push; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  AtlasColourSample s = SampleRef(push.sampleAddress).samples[i];
  vec3 bary = vec3(1.0 - s.bary1 - s.bary2, s.bary1, s.bary2);
  vec4 c = shadeTrianglePoint(uvec3(s.vertices[0], s.vertices[1], s.vertices[2]), s.instance, s.material, bary,
                              vec3(-1.0, 1.0, 0.0), vec3(-1.0, 0.0, 1.0), push.frameAddress, push.vertexAddress,
                              push.instanceAddress, push.materialAddress);
  OutputRef(push.outputAddress).colors[i] = packUnorm4x8(encodeAtlasColor(c));
}
