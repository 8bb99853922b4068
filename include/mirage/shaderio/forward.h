// Structs shared by C++ and GLSL for the forward renderer: written once, compiled by both
// (vk_lod_clusters' shaderio habit). GLSL reads them with scalar block layout through buffer
// device addresses, so C++ sizes must match exactly: see the static_asserts.
#ifndef MIRAGE_SHADERIO_FORWARD_H
#define MIRAGE_SHADERIO_FORWARD_H

#include "mirage/shaderio/view.h"

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using vec2 = glm::vec2;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using mat4 = glm::mat4;
using uint = uint32_t;
#endif

// Alpha modes as in glTF.
#define MIRAGE_ALPHA_OPAQUE 0
#define MIRAGE_ALPHA_MASK 1
#define MIRAGE_ALPHA_BLEND 2

// Shading models (core ShadingModel; formulas in docs/shading.md).
#define MIRAGE_MODEL_METALLIC_ROUGHNESS 0
#define MIRAGE_MODEL_BLINN_PHONG 1

// The maps of a material, each with its own UV transform (core MaterialMap, same order).
#define MIRAGE_MAP_BASE_COLOR 0
#define MIRAGE_MAP_METALLIC_ROUGHNESS 1
#define MIRAGE_MAP_NORMAL 2
#define MIRAGE_MAP_OCCLUSION 3
#define MIRAGE_MAP_EMISSIVE 4
#define MIRAGE_MAP_DETAIL_ALBEDO 5
#define MIRAGE_MAP_DETAIL_NORMAL 6
#define MIRAGE_MAP_DETAIL_MASK 7
#define MIRAGE_MATERIAL_MAPS 8
// constant_id of shading.glsl's kMaterialMaps (bit MIRAGE_MAP_k: the pipeline may meet map k). Not
// used by any other shader that includes shading.glsl (cluster_raster.glsl's kEyes is 0).
#define MIRAGE_SPEC_MATERIAL_MAPS 4

// One vertex as the vertex input reads it (52 bytes, tightly packed).
struct GpuVertex {
  vec3 position;
  vec3 normal;
  vec2 uv;
  vec4 tangent; // w = handedness; w == 0: no tangents, the fragment shader derives a frame from derivatives
  uint color;   // RGBA8 unorm, linear
};

// Per frame: camera and lighting.
struct FrameData {
  ViewFrame camera;
  vec4 lightDir;         // xyz direction towards the light (normalized), w intensity
  vec4 skyAmbient;       // rgb ambient from above
  vec4 groundAmbient;    // rgb ambient from below
  uint64_t lightAddress; // GpuPointLight[lightCount]
  uint lightCount;
  uint pad0;
};

// A point light (core PointLight): colour already multiplied by its intensity.
struct GpuPointLight {
  vec3 position;
  float radius; // > 0: no light at or beyond it
  vec3 color;   // linear RGB x intensity
  float pad0;
};

// Per instance: object-to-world and its normal matrix (inverse transpose), both as mat4 for alignment.
struct GpuInstance {
  mat4 model;
  mat4 normalMatrix;
};

// A material (core Material): glTF metallic-roughness or Blinn-Phong, with the detail maps; texture
// indices into the bindless array, -1 for none.
struct GpuMaterial {
  vec4 baseColorFactor;
  vec3 emissiveFactor;
  float metallicFactor;
  float roughnessFactor;
  float normalScale;
  float occlusionStrength;
  float alphaCutoff;
  int baseColorTexture;
  int metallicRoughnessTexture;
  int normalTexture;
  int occlusionTexture;
  int emissiveTexture;
  uint alphaMode;
  uint doubleSided;
  uint shadingModel;  // MIRAGE_MODEL_*
  vec3 specularColor; // Blinn-Phong
  float glossiness;   // Blinn-Phong, 0..1
  int detailAlbedoTexture;
  int detailNormalTexture;
  int detailMaskTexture;
  uint pad0;
  // GpuMapTransform[MIRAGE_MATERIAL_MAPS] of this material, read only where a map is sampled: kept
  // in the record, the 48 floats were loaded with it and took the cluster resolve from 72 to 128
  // registers (0.035 -> 0.048 ms, 2500 blobs at 1080p on an H100).
  uint64_t mapTransformAddress;
};

// A map's UV transform (MIRAGE_MAP_*): uv' = vec2(dot(row0, vec3(uv, 1)), dot(row1, vec3(uv, 1))).
struct GpuMapTransform {
  vec3 row0;
  vec3 row1;
};

// Push constants of the forward pipelines (<= 128 bytes, the guaranteed minimum).
struct ForwardPush {
  uint64_t frameAddress;    // FrameData
  uint64_t instanceAddress; // GpuInstance[]
  uint64_t materialAddress; // GpuMaterial[]
  uint materialIndex;
  uint pad0;
  uint64_t oitAddress; // OitLists (shaderio/oit.h) of the linked-list transparency pass, else 0
};

// Push constants of the forward transparency resolves (forward_oit_resolve.comp,
// forward_weighted_resolve.comp): their colour targets are descriptors, the lists an address.
struct ForwardResolvePush {
  uint64_t oitAddress; // OitLists
  uint width;          // target pixels (both eyes in stereo)
  uint height;
};

// Push constants of the forward targets' compute clears (forward_clear.comp,
// forward_weighted_clear.comp; the resolves' descriptor sets).
struct ForwardClearPush {
  vec4 value;
  uint width; // target pixels (both eyes in stereo)
  uint height;
  uint pad0, pad1;
};

#ifdef __cplusplus
static_assert(sizeof(GpuVertex) == 52, "GpuVertex layout");
static_assert(sizeof(FrameData) == 432, "FrameData layout");
static_assert(sizeof(GpuPointLight) == 32, "GpuPointLight layout");
static_assert(sizeof(GpuInstance) == 128, "GpuInstance layout");
static_assert(sizeof(GpuMaterial) == 120, "GpuMaterial layout");
static_assert(sizeof(GpuMapTransform) == 24, "GpuMapTransform layout");
static_assert(sizeof(ForwardPush) == 40, "ForwardPush layout");
static_assert(sizeof(ForwardResolvePush) == 16, "ForwardResolvePush layout");
static_assert(sizeof(ForwardClearPush) == 32, "ForwardClearPush layout");
} // namespace mirage::shaderio
#endif

#endif
