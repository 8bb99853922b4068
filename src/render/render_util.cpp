#include "render_util.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/packing.hpp>

#include "mirage/core/color.h"

namespace mirage::render {

shaderio::GpuMaterial toGpuMaterial(const Material& m, size_t textureCount) {
  auto tex = [&](int32_t t) { return t >= 0 && size_t(t) < textureCount ? t : -1; };
  shaderio::GpuMaterial g{};
  g.baseColorFactor = m.baseColorFactor;
  g.emissiveFactor = m.emissiveFactor;
  g.metallicFactor = m.metallicFactor;
  g.roughnessFactor = m.roughnessFactor;
  g.normalScale = m.normalScale;
  g.occlusionStrength = m.occlusionStrength;
  g.alphaCutoff = m.alphaCutoff;
  g.baseColorTexture = tex(m.baseColorTexture);
  g.metallicRoughnessTexture = tex(m.metallicRoughnessTexture);
  g.normalTexture = tex(m.normalTexture);
  g.occlusionTexture = tex(m.occlusionTexture);
  g.emissiveTexture = tex(m.emissiveTexture);
  g.alphaMode = m.alphaMode == AlphaMode::Mask    ? MIRAGE_ALPHA_MASK
                : m.alphaMode == AlphaMode::Blend ? MIRAGE_ALPHA_BLEND
                                                  : MIRAGE_ALPHA_OPAQUE;
  g.doubleSided = m.doubleSided;
  return g;
}

void convertHalfImage(const std::vector<uint8_t>& rgba16f, uint32_t width, uint32_t height, bool keepLinear,
                      RenderOutput& out) {
  const uint16_t* half = reinterpret_cast<const uint16_t*>(rgba16f.data());
  size_t values = size_t(width) * height * 4;
  out.srgb = ImageRGBA8{width, height, std::vector<uint8_t>(values)};
  if (keepLinear) out.linear = ImageF32{width, height, std::vector<float>(values)};
  for (size_t i = 0; i < values; ++i) {
    float v = glm::unpackHalf1x16(half[i]);
    out.srgb.pixels[i] = (i & 3) == 3 ? uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)) : linearToSrgb8(v);
    if (keepLinear) out.linear.pixels[i] = v;
  }
}

} // namespace mirage::render
