#pragma once
// SPIR-V of every shader in shaders/, compiled by glslc at build time and embedded in the binary.
#include <cstdint>
#include <span>
#include <string_view>

namespace mirage::gpu {

// Code of shader file `name` (e.g. "forward.vert"); empty span when unknown.
std::span<const uint32_t> shaderCode(std::string_view name);

} // namespace mirage::gpu
