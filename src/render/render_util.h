#pragma once
// Pieces every renderer shares (private to src/render).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/shaderio/forward.h"

namespace mirage::render {

// Synchronization2 shorthands of the compute passes' barriers.
constexpr VkPipelineStageFlags2 kCS = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkAccessFlags2 kStorageRW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;

// Linear filtering with repeat and trilinear mips (material textures), or nearest with clamp
// (integer targets such as the visibility image).
gpu::Unique<VkSampler> makeSampler(gpu::Context& ctx, VkFilter filter);
// The scene's textures as sampled images: sRGB or UNORM by use, full mip chains; one white texel
// when the scene has none (a descriptor array cannot be empty).
std::vector<gpu::Image> uploadTextures(gpu::Context& ctx, const Scene& scene);

// The material as shaders read it; texture indices outside [0, textureCount) become -1; its map
// transforms at `mapTransformAddress` (toGpuMapTransforms).
shaderio::GpuMaterial toGpuMaterial(const Material& m, size_t textureCount, uint64_t mapTransformAddress);
std::array<shaderio::GpuMapTransform, MIRAGE_MATERIAL_MAPS> toGpuMapTransforms(const Material& m);
// GpuMaterial[] of `materials` (returned) and their map transforms (into `mapTransforms`, which
// must live as long as the materials buffer).
gpu::Buffer uploadMaterials(gpu::Context& ctx, const std::vector<Material>& materials, size_t textureCount,
                            gpu::Buffer& mapTransforms, const char* name);
// shading.glsl's kMaterialMaps for a pipeline shading `materials`: with MIRAGE_SPECIALIZE_MAPS=1
// the maps some material has (bit MIRAGE_MAP_k), else every bit (each map decided per material, one
// pipeline for any scene). Returned as a compute pipeline's specialization values (constant_id i
// takes value i; the others are 0, which no shader including shading.glsl declares).
std::vector<uint32_t> materialMapSpecialization(const std::vector<Material>& materials, size_t textureCount);
// The scene's point lights as shaders read them (colour x intensity).
std::vector<shaderio::GpuPointLight> toGpuLights(const std::vector<PointLight>& lights);
// GpuPointLight[] of `lights`; one unused entry when there are none (a buffer cannot be empty, and
// shaders read lightCount first).
gpu::Buffer uploadLights(gpu::Context& ctx, const std::vector<PointLight>& lights, const char* name);

// The scene's meshes merged as the forward renderer and the atlas stages upload them: one vertex
// list (meshes in scene order; missing normals (0, 1, 0), uvs 0, tangents 0, colours white) and
// one index list of mesh-local indices; per mesh its first vertex and first index.
struct MergedGeometry {
  std::vector<shaderio::GpuVertex> vertices;
  std::vector<uint32_t> indices;
  std::vector<uint32_t> firstVertex, firstIndex;
};
MergedGeometry mergeSceneGeometry(const Scene& scene);

// RGBA16F pixels read back from a colour target -> 8-bit sRGB (alpha linear) and, when
// `keepLinear`, the float image.
void convertHalfImage(const std::vector<uint8_t>& rgba16f, uint32_t width, uint32_t height, bool keepLinear,
                      RenderOutput& out);

} // namespace mirage::render
