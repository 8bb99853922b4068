#pragma once
// Pieces every renderer shares (private to src/render).
#include <cstdint>
#include <vector>

#include "mirage/core/scene.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/shaderio/forward.h"

namespace mirage::render {

// The glTF material as shaders read it; texture indices outside [0, textureCount) become -1.
shaderio::GpuMaterial toGpuMaterial(const Material& m, size_t textureCount);

// RGBA16F pixels read back from a colour target -> 8-bit sRGB (alpha linear) and, when
// `keepLinear`, the float image.
void convertHalfImage(const std::vector<uint8_t>& rgba16f, uint32_t width, uint32_t height, bool keepLinear,
                      RenderOutput& out);

} // namespace mirage::render
