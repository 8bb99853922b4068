#include "render_util.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string_view>

#include <glm/gtc/packing.hpp>

#include "mirage/core/color.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

gpu::Unique<VkSampler> makeSampler(gpu::Context& ctx, VkFilter filter) {
  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = si.minFilter = filter;
  si.mipmapMode = filter == VK_FILTER_LINEAR ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST;
  si.addressModeU = si.addressModeV = si.addressModeW =
      filter == VK_FILTER_LINEAR ? VK_SAMPLER_ADDRESS_MODE_REPEAT : VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  si.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler s;
  MIRAGE_VK_CHECK(vkCreateSampler(ctx.device(), &si, nullptr, &s));
  return gpu::Unique<VkSampler>(ctx.device(), s);
}

// sRGB or UNORM by use, full mip chains, one white texel
// when the scene has none (a descriptor array cannot be empty).
std::vector<gpu::Image> uploadTextures(gpu::Context& ctx, const Scene& scene) {
  std::vector<Texture> list = scene.textures;
  if (list.empty()) list.push_back(Texture{"white", 1, 1, {255, 255, 255, 255}, false});
  std::vector<gpu::Image> out;
  for (const Texture& t : list) {
    uint32_t mips = gpu::mipLevelCount(t.width, t.height);
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = t.srgb ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM;
    ci.extent = {t.width, t.height, 1};
    ci.mipLevels = mips;
    ci.arrayLayers = 1;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    gpu::Image img = gpu::createImage(ctx, ci, VK_IMAGE_ASPECT_COLOR_BIT, t.name.c_str());
    gpu::uploadTextureRGBA8(ctx, img, t.rgba8.data(), t.width, t.height, mips);
    out.push_back(std::move(img));
  }
  return out;
}

shaderio::GpuMaterial toGpuMaterial(const Material& m, size_t textureCount, uint64_t mapTransformAddress) {
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
  g.shadingModel = m.model == ShadingModel::BlinnPhong ? MIRAGE_MODEL_BLINN_PHONG : MIRAGE_MODEL_METALLIC_ROUGHNESS;
  g.specularColor = m.specularColor;
  g.glossiness = m.glossiness;
  g.detailAlbedoTexture = tex(m.detailAlbedoTexture);
  g.detailNormalTexture = tex(m.detailNormalTexture);
  g.detailMaskTexture = tex(m.detailMaskTexture);
  g.mapTransformAddress = mapTransformAddress;
  return g;
}

std::array<shaderio::GpuMapTransform, MIRAGE_MATERIAL_MAPS> toGpuMapTransforms(const Material& m) {
  std::array<shaderio::GpuMapTransform, MIRAGE_MATERIAL_MAPS> out{};
  for (int map = 0; map < kMaterialMapCount; ++map) {
    // KHR_texture_transform: uv' = offset + R * (scale * uv), R = [cos sin; -sin cos].
    const UvTransform& t = m.uv[map];
    float c = std::cos(t.rotation), s = std::sin(t.rotation);
    out[map].row0 = {c * t.scale.x, s * t.scale.y, t.offset.x};
    out[map].row1 = {-s * t.scale.x, c * t.scale.y, t.offset.y};
  }
  return out;
}

gpu::Buffer uploadMaterials(gpu::Context& ctx, const std::vector<Material>& materials, size_t textureCount,
                            gpu::Buffer& mapTransforms, const char* name) {
  std::vector<shaderio::GpuMapTransform> transforms;
  for (const Material& m : materials) {
    auto t = toGpuMapTransforms(m);
    transforms.insert(transforms.end(), t.begin(), t.end());
  }
  if (transforms.empty()) transforms.resize(MIRAGE_MATERIAL_MAPS); // the buffer still needs an address
  mapTransforms =
      gpu::createBufferWithData<shaderio::GpuMapTransform>(ctx, transforms, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, name);
  std::vector<shaderio::GpuMaterial> records;
  for (size_t i = 0; i < materials.size(); ++i)
    records.push_back(
        toGpuMaterial(materials[i], textureCount,
                      mapTransforms.address() + i * MIRAGE_MATERIAL_MAPS * sizeof(shaderio::GpuMapTransform)));
  return gpu::createBufferWithData<shaderio::GpuMaterial>(ctx, records, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, name);
}

// The shader's map and model numbers are core's enums.
static_assert(MIRAGE_MATERIAL_MAPS == kMaterialMapCount && MIRAGE_MAP_BASE_COLOR == kMapBaseColor &&
              MIRAGE_MAP_METALLIC_ROUGHNESS == kMapMetallicRoughness && MIRAGE_MAP_NORMAL == kMapNormal &&
              MIRAGE_MAP_OCCLUSION == kMapOcclusion && MIRAGE_MAP_EMISSIVE == kMapEmissive &&
              MIRAGE_MAP_DETAIL_ALBEDO == kMapDetailAlbedo && MIRAGE_MAP_DETAIL_NORMAL == kMapDetailNormal &&
              MIRAGE_MAP_DETAIL_MASK == kMapDetailMask);

std::vector<uint32_t> materialMapSpecialization(const std::vector<Material>& materials, size_t textureCount) {
  std::vector<uint32_t> values(MIRAGE_SPEC_MATERIAL_MAPS + 1, 0u);
  uint32_t mask = ~0u;
  // Specialized by default: absent maps compile away (H100, 2500 untextured blobs: resolve 0.036 ->
  // 0.032 ms, stereo 0.132 -> 0.118, same run). MIRAGE_SPECIALIZE_MAPS=0 keeps every map's branch,
  // one pipeline for any material, to compare.
  const char* env = std::getenv("MIRAGE_SPECIALIZE_MAPS");
  if (!env || std::string_view(env) != "0") {
    mask = 0;
    for (const Material& m : materials) {
      const int32_t maps[kMaterialMapCount] = {m.baseColorTexture,    m.metallicRoughnessTexture, m.normalTexture,
                                               m.occlusionTexture,    m.emissiveTexture,          m.detailAlbedoTexture,
                                               m.detailNormalTexture, m.detailMaskTexture}; // MaterialMap order
      for (int k = 0; k < kMaterialMapCount; ++k)
        if (maps[k] >= 0 && size_t(maps[k]) < textureCount) mask |= 1u << k;
    }
  }
  values[MIRAGE_SPEC_MATERIAL_MAPS] = mask;
  return values;
}

std::vector<shaderio::GpuPointLight> toGpuLights(const std::vector<PointLight>& lights) {
  std::vector<shaderio::GpuPointLight> out;
  for (const PointLight& l : lights) out.push_back({l.position, l.radius, l.color * l.intensity, 0.0f});
  return out;
}

gpu::Buffer uploadLights(gpu::Context& ctx, const std::vector<PointLight>& lights, const char* name) {
  std::vector<shaderio::GpuPointLight> records = toGpuLights(lights);
  if (records.empty()) records.resize(1);
  return gpu::createBufferWithData<shaderio::GpuPointLight>(ctx, records, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, name);
}

namespace {
uint32_t packColor(const glm::vec4& c) {
  glm::vec4 v = glm::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f;
  return uint32_t(v.r) | uint32_t(v.g) << 8 | uint32_t(v.b) << 16 | uint32_t(v.a) << 24;
}
} // namespace

MergedGeometry mergeSceneGeometry(const Scene& scene) {
  MergedGeometry g;
  size_t nv = 0, ni = 0;
  for (const Mesh& m : scene.meshes) nv += m.positions.size(), ni += m.indices.size();
  g.vertices.reserve(nv);
  g.indices.reserve(ni);
  for (const Mesh& m : scene.meshes) {
    g.firstVertex.push_back(uint32_t(g.vertices.size()));
    g.firstIndex.push_back(uint32_t(g.indices.size()));
    for (size_t i = 0; i < m.positions.size(); ++i) {
      shaderio::GpuVertex v{};
      v.position = m.positions[i];
      v.normal = i < m.normals.size() ? m.normals[i] : glm::vec3(0, 1, 0);
      v.uv = i < m.uv0.size() ? m.uv0[i] : glm::vec2(0.0f);
      v.tangent = i < m.tangents.size() ? m.tangents[i] : glm::vec4(0.0f);
      v.color = i < m.colors.size() ? packColor(m.colors[i]) : 0xffffffffu;
      g.vertices.push_back(v);
    }
    g.indices.insert(g.indices.end(), m.indices.begin(), m.indices.end());
  }
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
