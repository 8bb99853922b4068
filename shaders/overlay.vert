#version 460
// The viewer overlay (Dear ImGui draw lists): 2D vertices in pixels mapped to clip space.
layout(location = 0) in vec2 inPosition;
layout(location = 1) in vec2 inUv;
layout(location = 2) in vec4 inColor; // R8G8B8A8_UNORM

layout(push_constant) uniform Push {
  vec2 scale;     // 2 / framebuffer size
  vec2 translate; // -1 - displayPos * scale
};

layout(location = 0) out vec4 outColor;
layout(location = 1) out vec2 outUv;

void main() {
  outColor = inColor;
  outUv = inUv;
  gl_Position = vec4(inPosition * scale + translate, 0.0, 1.0);
}
