#version 460
// The atlas zeroed before a client's blocks are shaded (AtlasShading::clearAtlas): a compute store
// writes at memory speed where vkCmdClearColorImage runs at the fixed-function rate on some GPUs
// (docs/stream.md, "Formats"). The atlas side is a multiple of the 128-texel superblock, so every
// invocation has a texel.
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D atlas;
layout(local_size_x = 8, local_size_y = 8) in;

void main() { imageStore(atlas, ivec2(gl_GlobalInvocationID.xy), vec4(0.0)); }
