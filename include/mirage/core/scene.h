#pragma once
// The in-memory scene model every subsystem shares: importers fill it, the LOD builder, surfel
// sampler and PVS baker read it, renderers draw it. Plain data, flattened: each mesh is one
// triangle list with one material; instances place meshes with world transforms.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace mirage {

struct Bounds {
  glm::vec3 min{1e30f};
  glm::vec3 max{-1e30f};
  bool empty() const { return min.x > max.x; }
  glm::vec3 center() const { return (min + max) * 0.5f; }
  glm::vec3 extent() const { return max - min; }
  float radius() const { return empty() ? 0.0f : glm::length(max - min) * 0.5f; }
  void add(glm::vec3 p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  void add(const Bounds& b) {
    if (!b.empty()) {
      add(b.min);
      add(b.max);
    }
  }
};

// A decoded texture image, RGBA 8 bit. Colour textures are sRGB-encoded (the sampler decodes them).
struct Texture {
  std::string name; // file name or "embedded #N"
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba8; // width * height * 4 bytes
  bool srgb = true;           // true for baseColor/emissive, false for data maps (normal, ORM)
};

enum class AlphaMode : uint8_t { Opaque, Mask, Blend };

// How a material reflects light (docs/shading.md has the formulas): glTF metallic-roughness (GGX),
// or the Blinn-Phong model of the material files (glossiness, specular colour).
enum class ShadingModel : uint8_t { MetallicRoughness, BlinnPhong };

// A texture coordinate transform as glTF's KHR_texture_transform (ratified form):
// uv' = offset + R(rotation) * (scale * uv), R = [cos sin; -sin cos] (counter-clockwise in uv).
struct UvTransform {
  glm::vec2 offset{0.0f};
  glm::vec2 scale{1.0f};
  float rotation = 0.0f; // radians
};

// The maps of a material, each with its own UV transform (Material::uv).
enum MaterialMap : uint8_t {
  kMapBaseColor,
  kMapMetallicRoughness,
  kMapNormal,
  kMapOcclusion,
  kMapEmissive,
  kMapDetailAlbedo,
  kMapDetailNormal,
  kMapDetailMask,
  kMaterialMapCount
};

// A material: glTF metallic-roughness (what importers fill) or Blinn-Phong, plus the seed's detail
// maps, from a material file (mirage/shading/material_file.h). Texture fields index
// Scene::textures, -1 for none.
struct Material {
  std::string name;
  std::string origin; // where it was defined, "<file>:<line>" (a material file); empty: the scene file
  glm::vec4 baseColorFactor{1.0f};
  glm::vec3 emissiveFactor{0.0f};
  float metallicFactor = 1.0f;
  float roughnessFactor = 1.0f;
  float normalScale = 1.0f;
  float occlusionStrength = 1.0f;
  float alphaCutoff = 0.5f; // used when alphaMode == Mask
  AlphaMode alphaMode = AlphaMode::Opaque;
  bool doubleSided = false;
  int32_t baseColorTexture = -1;
  int32_t metallicRoughnessTexture = -1; // G = roughness, B = metallic
  int32_t normalTexture = -1;            // tangent space
  int32_t occlusionTexture = -1;         // R
  int32_t emissiveTexture = -1;
  ShadingModel model = ShadingModel::MetallicRoughness;
  glm::vec3 specularColor{0.04f}; // Blinn-Phong: specular reflectance (linear RGB)
  float glossiness = 0.5f;        // Blinn-Phong: 0..1, exponent 2^(1 + 10 glossiness) (2..2048)
  // Detail maps (the seed's): albedo x (2 x detail albedo) and the detail normal blended in, both by
  // the mask's R (1 without a mask texture). The detail albedo is a data map (0.5 = no change).
  int32_t detailAlbedoTexture = -1;
  int32_t detailNormalTexture = -1;
  int32_t detailMaskTexture = -1;
  UvTransform uv[kMaterialMapCount]; // per map, indexed by MaterialMap
};

// A point light besides the key light: colour x intensity, windowed inverse-square falloff that
// reaches 0 at `radius` (docs/shading.md, "Point lights").
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 color{1.0f}; // linear RGB
  float intensity = 1.0f;
  float radius = 10.0f; // > 0: no light at or beyond it
};

// One triangle list with one material. Optional attributes are empty or have positions.size() entries.
struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // always filled after import (computed when missing)
  std::vector<glm::vec4> tangents; // optional; w = handedness
  std::vector<glm::vec2> uv0;      // optional
  std::vector<glm::vec4> colors;   // optional, linear RGBA
  std::vector<uint32_t> indices;   // 3 per triangle
  uint32_t material = 0;           // index into Scene::materials
  Bounds bounds;                   // object space

  size_t vertexCount() const { return positions.size(); }
  size_t triangleCount() const { return indices.size() / 3; }
};

struct Instance {
  uint32_t mesh = 0;
  glm::mat4 transform{1.0f}; // object to world
};

struct Scene {
  std::string source; // file it came from, or "generated:<kind>"
  std::vector<Mesh> meshes;
  std::vector<Material> materials; // never empty after import: index 0 may be a default material
  std::vector<Texture> textures;
  std::vector<Instance> instances;
  std::vector<PointLight> lights; // besides the renderer's key light

  // Sum over instances of their mesh's triangles (what a renderer draws).
  size_t instancedTriangleCount() const;
  // Sum over unique meshes.
  size_t meshTriangleCount() const;
  // World-space bounds of all instances.
  Bounds worldBounds() const;
};

// Transform an object-space box to a world-space box (the box of its 8 transformed corners).
Bounds transformBounds(const Bounds& b, const glm::mat4& m);

// Largest length of the transform's three axes: how much it can stretch object-space distances
// (LOD errors and bounding-sphere radii are scaled by it).
float maxAxisScale(const glm::mat4& m);

// The seed's benchmark scenes: `copies` copies of all the scene's instances on a square grid in the
// ground (xz) plane, row by row (ceil(sqrt(copies)) per row), centred on the original, spaced by
// 1.25x the scene's largest horizontal extent so copies never overlap. Meshes are shared, not copied.
void repeatOnGrid(Scene& scene, uint32_t copies);

} // namespace mirage
