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
  vec4 lightDir;      // xyz direction towards the light (normalized), w intensity
  vec4 skyAmbient;    // rgb ambient from above
  vec4 groundAmbient; // rgb ambient from below
};

// Per instance: object-to-world and its normal matrix (inverse transpose), both as mat4 for alignment.
struct GpuInstance {
  mat4 model;
  mat4 normalMatrix;
};

// glTF metallic-roughness material; texture indices into the bindless array, -1 for none.
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
  uint pad0;
};

// Push constants of the forward pipelines (<= 128 bytes, the guaranteed minimum).
struct ForwardPush {
  uint64_t frameAddress;    // FrameData
  uint64_t instanceAddress; // GpuInstance[]
  uint64_t materialAddress; // GpuMaterial[]
  uint materialIndex;
  uint pad0;
};

#ifdef __cplusplus
static_assert(sizeof(GpuVertex) == 52, "GpuVertex layout");
static_assert(sizeof(FrameData) == 416, "FrameData layout");
static_assert(sizeof(GpuInstance) == 128, "GpuInstance layout");
static_assert(sizeof(GpuMaterial) == 80, "GpuMaterial layout");
static_assert(sizeof(ForwardPush) == 32, "ForwardPush layout");
} // namespace mirage::shaderio
#endif

#endif
