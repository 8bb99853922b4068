#version 460
// The viewer's present path: a copy of the scene's RGBA16F linear colour target (as a buffer) to
// 8-bit sRGB in the swapchain's channel order, for vkCmdCopyBufferToImage into the swapchain
// image. Encodes as mirage::linearToSrgb8 (core/color.cpp) and alpha as convertHalfImage does, so
// the presented bytes are those of the readback path.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(local_size_x = 256) in;
layout(buffer_reference, scalar) readonly buffer HalfPixels { uvec2 v[]; };
layout(buffer_reference, scalar) writeonly buffer Packed { uint v[]; };
layout(push_constant, scalar) uniform Push {
  uint64_t src;
  uint64_t dst;
  uint pixels;
  uint bgra; // 1: B8G8R8A8 swapchain
} push;

float encode(float v) {
  v = isnan(v) ? 0.0 : clamp(v, 0.0, 1.0);
  float s = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
  return floor(s * 255.0 + 0.5); // std::lround
}

void main() {
  uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 256;
  if (i >= push.pixels) return;
  uvec2 h = HalfPixels(push.src).v[i];
  vec4 c = vec4(unpackHalf2x16(h.x), unpackHalf2x16(h.y));
  uvec4 q = uvec4(encode(c.r), encode(c.g), encode(c.b), floor(clamp(isnan(c.a) ? 0.0 : c.a, 0.0, 1.0) * 255.0 + 0.5));
  if (push.bgra != 0) q = q.bgra;
  Packed(push.dst).v[i] = q.x | (q.y << 8) | (q.z << 16) | (q.w << 24);
}
