// Object-space shading of the atlas stages (atlas_shade.comp, atlas_colour.comp): a point of a
// scene triangle given by barycentrics (any sign: points outside the triangle extrapolate its
// attributes), shaded with the one material model of shading.glsl as forward.vert/forward.frag
// shade it, with derivatives from the footprint instead of dFdx/dFdy.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/forward.h"
#include "mirage/shaderio/atlas.h"
#include "mirage/shaderio/atlas_shading.h"

layout(set = 0, binding = 0) uniform sampler2D textures[];

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer FrameRef { FrameData frame; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer VertexRef { GpuVertex vertices[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer InstanceRef { GpuInstance instances[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MaterialRef { GpuMaterial materials[]; };

#include "shading.glsl"

// The forward renderer's 8-bit output of a linear value (mirage::linearToSrgb8), in k / 255 steps
// so an RGBA8 UNORM store keeps it exactly.
float encodeSrgb(float v) {
  v = isnan(v) ? 0.0 : clamp(v, 0.0, 1.0);
  float s = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
  return floor(s * 255.0 + 0.5) / 255.0;
}
vec4 encodeAtlasColor(vec4 linear) {
  float a = isnan(linear.a) ? 0.0 : clamp(linear.a, 0.0, 1.0);
  return vec4(encodeSrgb(linear.r), encodeSrgb(linear.g), encodeSrgb(linear.b), floor(a * 255.0 + 0.5) / 255.0);
}

// Shaded colour (linear rgb, alpha as the forward renderer: base alpha for BLEND, the cutoff's 0/1
// for MASK, 1 for OPAQUE) of the point with barycentrics `bary` of triangle `v` (merged vertex
// indices in winding order) of instance `instance`. dbdx, dbdy: the barycentrics' change per step
// of the footprint (one texel across and down), the derivatives' source for texture LOD and
// derivative tangent frames.
vec4 shadeTrianglePoint(uvec3 v, uint instance, uint material, vec3 bary, vec3 dbdx, vec3 dbdy, uint64_t frameAddress,
                        uint64_t vertexAddress, uint64_t instanceAddress, uint64_t materialAddress) {
  FrameData frame = FrameRef(frameAddress).frame;
  GpuInstance inst = InstanceRef(instanceAddress).instances[instance];
  GpuMaterial m = MaterialRef(materialAddress).materials[material];
  GpuVertex c0 = VertexRef(vertexAddress).vertices[v.x];
  GpuVertex c1 = VertexRef(vertexAddress).vertices[v.y];
  GpuVertex c2 = VertexRef(vertexAddress).vertices[v.z];
  // As forward.vert: world position, normal by the normal matrix, tangent by the model matrix.
  vec3 p0 = (inst.model * vec4(c0.position, 1.0)).xyz;
  vec3 p1 = (inst.model * vec4(c1.position, 1.0)).xyz;
  vec3 p2 = (inst.model * vec4(c2.position, 1.0)).xyz;
  mat3 toWorldNormal = mat3(inst.normalMatrix);
  mat3 toWorld = mat3(inst.model);

  vec3 worldPos = bary.x * p0 + bary.y * p1 + bary.z * p2;
  vec3 normal = toWorldNormal * (bary.x * c0.normal + bary.y * c1.normal + bary.z * c2.normal);
  vec4 tangent = bary.x * c0.tangent + bary.y * c1.tangent + bary.z * c2.tangent;
  tangent = vec4(toWorld * tangent.xyz, tangent.w); // w interpolated too, as forward.vert's output
  vec2 uv = bary.x * c0.uv + bary.y * c1.uv + bary.z * c2.uv;
  vec4 color = bary.x * unpackUnorm4x8(c0.color) + bary.y * unpackUnorm4x8(c1.color) + bary.z * unpackUnorm4x8(c2.color);

  SurfaceDerivatives d;
  d.dpdx = dbdx.x * p0 + dbdx.y * p1 + dbdx.z * p2;
  d.dpdy = dbdy.x * p0 + dbdy.y * p1 + dbdy.z * p2;
  d.duvdx = dbdx.x * c0.uv + dbdx.y * c1.uv + dbdx.z * c2.uv;
  d.duvdy = dbdy.x * c0.uv + dbdy.y * c1.uv + dbdy.z * c2.uv;

  // Facing as the rasterizer decides it: the triangle's winding seen from the eye, flipped for
  // mirrored instances (the forward renderer sets a clockwise front face for them). Single-sided
  // back faces are culled there, so only double-sided materials ever shade a back face.
  vec3 eye = frame.camera.eye.xyz;
  float mirrored = determinant(toWorld) < 0.0 ? -1.0 : 1.0;
  bool frontFacing = m.doubleSided == 0u || mirrored * dot(cross(p1 - p0, p2 - p0), eye - worldPos) >= 0.0;

  vec4 base = baseColor(m, uv, color, d);
  vec3 rgb = shadeSurfaceLights(m, base, worldPos, normal, tangent, frontFacing, uv, d, eye, frame.lightDir,
                                frame.skyAmbient.rgb, frame.groundAmbient.rgb, frame.lightAddress, frame.lightCount);
  float alpha = 1.0;
  if (m.alphaMode == MIRAGE_ALPHA_BLEND) alpha = base.a;
  if (m.alphaMode == MIRAGE_ALPHA_MASK) alpha = base.a < m.alphaCutoff ? 0.0 : 1.0;
  return vec4(rgb, alpha);
}
