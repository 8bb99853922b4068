#version 460
// The viewer overlay: vertex colour times the font atlas (ImGui's white pixel for solid shapes).
layout(set = 0, binding = 0) uniform sampler2D fontAtlas;

layout(location = 0) in vec4 inColor;
layout(location = 1) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() { outColor = inColor * texture(fontAtlas, inUv); }
