// SCEN payload: a version varint, then textures, materials, meshes, instances and (version 2)
// point lights in that order, each list a varint count followed by its records (layout table in
// docs/asset.md).
#include "mirage/asset/scene_chunk.h"

#include <cmath>
#include <new>

#include <nlohmann/json.hpp>

#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"

namespace mirage::asset {
namespace {

// glm types are written byte for byte: they must be tightly packed floats.
static_assert(sizeof(glm::vec2) == 8 && sizeof(glm::vec3) == 12 && sizeof(glm::vec4) == 16);
static_assert(sizeof(glm::mat4) == 64);

template <class V> bool allFinite(const V& v) {
  for (int k = 0; k < V::length(); ++k)
    if (!std::isfinite(v[k])) return false;
  return true;
}
bool allFinite(float f) { return std::isfinite(f); }
bool allFinite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    if (!allFinite(m[c])) return false;
  return true;
}
template <class V> std::optional<size_t> firstNonFinite(const std::vector<V>& values) {
  for (size_t i = 0; i < values.size(); ++i)
    if (!allFinite(values[i])) return i;
  return std::nullopt;
}

std::string validateTexture(const Texture& t) {
  // width*height fits 64 bits for 32-bit sizes, but *4 does not: 2^31 x 2^31 wrapped to 0 and
  // matched an empty pixel array.
  if (uint64_t(t.width) * t.height >= (uint64_t(1) << 62))
    return "is " + std::to_string(t.width) + "x" + std::to_string(t.height) + ": too large";
  uint64_t expected = uint64_t(t.width) * t.height * 4;
  if (t.rgba8.size() != expected)
    return "has " + std::to_string(t.rgba8.size()) + " bytes, expected " + std::to_string(t.width) + "x" +
           std::to_string(t.height) + "x4 = " + std::to_string(expected);
  return {};
}

std::string validateMaterial(const Material& m, size_t textureCount) {
  if (!allFinite(m.baseColorFactor) || !allFinite(m.emissiveFactor) || !allFinite(m.metallicFactor) ||
      !allFinite(m.roughnessFactor) || !allFinite(m.normalScale) || !allFinite(m.occlusionStrength) ||
      !allFinite(m.alphaCutoff) || !allFinite(m.specularColor) || !allFinite(m.glossiness))
    return "has a NaN or infinite factor";
  for (const UvTransform& t : m.uv)
    if (!allFinite(t.offset) || !allFinite(t.scale) || !allFinite(t.rotation))
      return "has a NaN or infinite UV transform";
  if (uint8_t(m.alphaMode) > uint8_t(AlphaMode::Blend)) return "has an invalid alpha mode";
  if (uint8_t(m.model) > uint8_t(ShadingModel::BlinnPhong)) return "has an invalid shading model";
  const int32_t slots[] = {m.baseColorTexture, m.metallicRoughnessTexture, m.normalTexture,       m.occlusionTexture,
                           m.emissiveTexture,  m.detailAlbedoTexture,      m.detailNormalTexture, m.detailMaskTexture};
  for (int32_t t : slots)
    if (t < -1 || (t >= 0 && size_t(t) >= textureCount))
      return "references texture " + std::to_string(t) + " (" + std::to_string(textureCount) + " textures)";
  return {};
}

std::string validateMesh(const Mesh& m, size_t materialCount) {
  size_t n = m.positions.size();
  // Optional attributes are per vertex or absent; a short array would be read out of bounds later.
  auto sizeOk = [n](size_t s) { return s == 0 || s == n; };
  if (!sizeOk(m.normals.size()) || !sizeOk(m.tangents.size()) || !sizeOk(m.uv0.size()) || !sizeOk(m.colors.size()))
    return "has an attribute array whose size is neither 0 nor the vertex count " + std::to_string(n);
  if (m.indices.size() % 3 != 0) return "has " + std::to_string(m.indices.size()) + " indices, not a multiple of 3";
  for (size_t i = 0; i < m.indices.size(); ++i)
    if (m.indices[i] >= n)
      return "index " + std::to_string(i) + " = " + std::to_string(m.indices[i]) + " is out of range (" +
             std::to_string(n) + " vertices)";
  if (m.material >= materialCount)
    return "uses material " + std::to_string(m.material) + " (" + std::to_string(materialCount) + " materials)";
  if (auto i = firstNonFinite(m.positions)) return "position " + std::to_string(*i) + " is NaN or infinite";
  if (auto i = firstNonFinite(m.normals)) return "normal " + std::to_string(*i) + " is NaN or infinite";
  if (auto i = firstNonFinite(m.tangents)) return "tangent " + std::to_string(*i) + " is NaN or infinite";
  if (auto i = firstNonFinite(m.uv0)) return "uv0 " + std::to_string(*i) + " is NaN or infinite";
  if (auto i = firstNonFinite(m.colors)) return "color " + std::to_string(*i) + " is NaN or infinite";
  if (!allFinite(m.bounds.min) || !allFinite(m.bounds.max)) return "has NaN or infinite bounds";
  return {};
}

std::string validate(const Scene& s) {
  for (size_t i = 0; i < s.textures.size(); ++i)
    if (std::string p = validateTexture(s.textures[i]); !p.empty()) return "texture " + std::to_string(i) + " " + p;
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (std::string p = validateMaterial(s.materials[i], s.textures.size()); !p.empty())
      return "material " + std::to_string(i) + " " + p;
  for (size_t i = 0; i < s.meshes.size(); ++i)
    if (std::string p = validateMesh(s.meshes[i], s.materials.size()); !p.empty())
      return "mesh " + std::to_string(i) + " " + p;
  for (size_t i = 0; i < s.instances.size(); ++i) {
    const Instance& inst = s.instances[i];
    if (inst.mesh >= s.meshes.size())
      return "instance " + std::to_string(i) + " uses mesh " + std::to_string(inst.mesh) + " (" +
             std::to_string(s.meshes.size()) + " meshes)";
    if (!allFinite(inst.transform)) return "instance " + std::to_string(i) + " has a NaN or infinite transform";
  }
  for (size_t i = 0; i < s.lights.size(); ++i) {
    const PointLight& l = s.lights[i];
    if (!allFinite(l.position) || !allFinite(l.color) || !allFinite(l.intensity) || !allFinite(l.radius))
      return "light " + std::to_string(i) + " has a NaN or infinite value";
    if (!(l.radius > 0.0f) || l.intensity < 0.0f)
      return "light " + std::to_string(i) + " has radius " + std::to_string(l.radius) + " and intensity " +
             std::to_string(l.intensity) + " (radius > 0, intensity >= 0)";
  }
  return {};
}

// bool and enums are stored as bytes and range-checked: memcpy into a bool is undefined for 2..255.
bool readFlag(ByteReader& r, bool& out) {
  uint8_t b = 0;
  if (!r.read(b)) return false;
  if (b > 1) return r.fail("boolean byte " + std::to_string(b) + " is not 0 or 1");
  out = b != 0;
  return true;
}

void decodeTexture(ByteReader& r, Texture& t) {
  bool srgb = true;
  r.readString(t.name) && r.read(t.width) && r.read(t.height) && readFlag(r, srgb) && r.readArray(t.rgba8);
  t.srgb = srgb;
}

void decodeMaterial(ByteReader& r, Material& m) {
  uint8_t alpha = 0;
  bool doubleSided = false;
  r.readString(m.name) && r.read(m.baseColorFactor) && r.read(m.emissiveFactor) && r.read(m.metallicFactor) &&
      r.read(m.roughnessFactor) && r.read(m.normalScale) && r.read(m.occlusionStrength) && r.read(m.alphaCutoff) &&
      r.read(alpha) && readFlag(r, doubleSided) && r.read(m.baseColorTexture) && r.read(m.metallicRoughnessTexture) &&
      r.read(m.normalTexture) && r.read(m.occlusionTexture) && r.read(m.emissiveTexture);
  if (alpha > uint8_t(AlphaMode::Blend)) r.fail("alpha mode " + std::to_string(alpha) + " is invalid");
  m.alphaMode = AlphaMode(alpha <= uint8_t(AlphaMode::Blend) ? alpha : 0);
  m.doubleSided = doubleSided;
}

// Version 2's material fields, after the version 1 record.
void decodeMaterialV2(ByteReader& r, Material& m) {
  uint8_t model = 0;
  r.readString(m.origin) && r.read(model) && r.read(m.specularColor) && r.read(m.glossiness) &&
      r.read(m.detailAlbedoTexture) && r.read(m.detailNormalTexture) && r.read(m.detailMaskTexture);
  for (UvTransform& t : m.uv) r.read(t.offset) && r.read(t.scale) && r.read(t.rotation);
  if (model > uint8_t(ShadingModel::BlinnPhong)) r.fail("shading model " + std::to_string(model) + " is invalid");
  m.model = ShadingModel(model <= uint8_t(ShadingModel::BlinnPhong) ? model : 0);
}

void decodeLight(ByteReader& r, PointLight& l) {
  r.read(l.position) && r.read(l.color) && r.read(l.intensity) && r.read(l.radius);
}

void decodeMesh(ByteReader& r, Mesh& m) {
  r.readString(m.name) && r.read(m.material) && r.read(m.bounds.min) && r.read(m.bounds.max) &&
      r.readArray(m.positions) && r.readArray(m.normals) && r.readArray(m.tangents) && r.readArray(m.uv0) &&
      r.readArray(m.colors) && r.readArray(m.indices);
}

// Lists are read record by record (no reserve from the untrusted count): every record consumes at
// least one byte, so a corrupt count fails at the end of the data instead of allocating.
template <class T, class F> void decodeList(ByteReader& r, std::vector<T>& out, F&& decodeOne) {
  uint64_t n = 0;
  if (!r.readCount(n, r.remaining(), "list length")) return;
  for (uint64_t i = 0; i < n && r.ok(); ++i) decodeOne(r, out.emplace_back());
}

} // namespace

Status validateScene(const Scene& scene, const std::string& file) {
  if (std::string p = validate(scene); !p.empty()) return makeError(file, p);
  return Ok{};
}

std::vector<uint8_t> encodeScene(const Scene& s) {
  ByteWriter w;
  size_t estimate = 64;
  for (const Texture& t : s.textures) estimate += t.rgba8.size() + 64;
  for (const Mesh& m : s.meshes)
    estimate += m.positions.size() * 12 + m.normals.size() * 12 + m.tangents.size() * 16 + m.uv0.size() * 8 +
                m.colors.size() * 16 + m.indices.size() * 4 + 128;
  w.reserve(estimate + s.materials.size() * 128 + s.instances.size() * 72);

  w.writeVarint(kSceneChunkVersion);
  w.writeString(s.source);
  w.writeVarint(s.textures.size());
  for (const Texture& t : s.textures) {
    w.writeString(t.name);
    w.write(t.width);
    w.write(t.height);
    w.write(uint8_t(t.srgb));
    w.writeArray(std::span<const uint8_t>(t.rgba8));
  }
  w.writeVarint(s.materials.size());
  for (const Material& m : s.materials) {
    w.writeString(m.name);
    w.write(m.baseColorFactor);
    w.write(m.emissiveFactor);
    for (float f : {m.metallicFactor, m.roughnessFactor, m.normalScale, m.occlusionStrength, m.alphaCutoff}) w.write(f);
    w.write(uint8_t(m.alphaMode));
    w.write(uint8_t(m.doubleSided));
    for (int32_t t :
         {m.baseColorTexture, m.metallicRoughnessTexture, m.normalTexture, m.occlusionTexture, m.emissiveTexture})
      w.write(t);
    w.writeString(m.origin);
    w.write(uint8_t(m.model));
    w.write(m.specularColor);
    w.write(m.glossiness);
    for (int32_t t : {m.detailAlbedoTexture, m.detailNormalTexture, m.detailMaskTexture}) w.write(t);
    for (const UvTransform& t : m.uv) {
      w.write(t.offset);
      w.write(t.scale);
      w.write(t.rotation);
    }
  }
  w.writeVarint(s.meshes.size());
  for (const Mesh& m : s.meshes) {
    w.writeString(m.name);
    w.write(m.material);
    w.write(m.bounds.min);
    w.write(m.bounds.max);
    w.writeArray(std::span<const glm::vec3>(m.positions));
    w.writeArray(std::span<const glm::vec3>(m.normals));
    w.writeArray(std::span<const glm::vec4>(m.tangents));
    w.writeArray(std::span<const glm::vec2>(m.uv0));
    w.writeArray(std::span<const glm::vec4>(m.colors));
    w.writeArray(std::span<const uint32_t>(m.indices));
  }
  w.writeVarint(s.instances.size());
  for (const Instance& inst : s.instances) {
    w.write(inst.mesh);
    w.write(inst.transform);
  }
  w.writeVarint(s.lights.size());
  for (const PointLight& l : s.lights) {
    w.write(l.position);
    w.write(l.color);
    w.write(l.intensity);
    w.write(l.radius);
  }
  return w.take();
}

Result<Scene> decodeScene(std::span<const uint8_t> bytes, const std::string& fileForErrors) {
  std::string file = fileForErrors + ": SCEN";
  try {
    ByteReader r(bytes, file);
    Scene s;
    uint64_t version = 0;
    if (r.readVarint(version) && (version < kOldestSceneChunkVersion || version > kSceneChunkVersion))
      return makeError(file, "unsupported scene chunk version " + std::to_string(version) + " (this build reads " +
                                 std::to_string(kOldestSceneChunkVersion) + ".." + std::to_string(kSceneChunkVersion) +
                                 ")");
    bool v2 = version >= 2;
    r.readString(s.source);
    decodeList(r, s.textures, decodeTexture);
    decodeList(r, s.materials, [v2](ByteReader& rr, Material& m) {
      decodeMaterial(rr, m);
      if (v2) decodeMaterialV2(rr, m);
    });
    decodeList(r, s.meshes, decodeMesh);
    decodeList(r, s.instances, [](ByteReader& rr, Instance& i) { rr.read(i.mesh) && rr.read(i.transform); });
    if (v2) decodeList(r, s.lights, decodeLight);
    if (Status st = r.finish(); !st) return st.error();
    if (Status st = validateScene(s, file); !st) return st.error();
    return s;
  } catch (const std::bad_alloc&) {
    return makeError(file, "out of memory decoding " + std::to_string(bytes.size()) + " bytes");
  }
}

namespace {

std::string sceneMeta(const Scene& s) {
  size_t vertices = 0;
  for (const Mesh& m : s.meshes) vertices += m.vertexCount();
  nlohmann::json j = {{"generator", "mirage"},
                      // No blocked chunk: AssetWriter writes the file as version 1.
                      {"formatVersion", kMinFormatVersion},
                      {"sceneChunkVersion", kSceneChunkVersion},
                      {"source", s.source},
                      {"meshes", s.meshes.size()},
                      {"materials", s.materials.size()},
                      {"textures", s.textures.size()},
                      {"instances", s.instances.size()},
                      {"lights", s.lights.size()},
                      {"vertices", vertices},
                      {"triangles", s.meshTriangleCount()}};
  // dump() throws on invalid UTF-8 (a source path in another encoding); replace instead.
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
}

// META is informational, but a META that disagrees with SCEN means the file was assembled wrongly.
Status checkMeta(const std::vector<uint8_t>& bytes, const Scene& s, const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return makeError(path, "META chunk is not a JSON object");
  const std::pair<const char*, size_t> counts[] = {{"meshes", s.meshes.size()},
                                                   {"materials", s.materials.size()},
                                                   {"textures", s.textures.size()},
                                                   {"instances", s.instances.size()}};
  for (const auto& [key, n] : counts) {
    auto it = j.find(key);
    if (it == j.end() || !it->is_number_unsigned() || it->get<uint64_t>() != n)
      return makeError(path, std::string("META ") + key + " does not match the SCEN chunk (" + std::to_string(n) + ")");
  }
  return Ok{};
}

} // namespace

Status saveScene(const std::string& path, const Scene& scene, int zstdLevel) {
  try {
    if (Status st = validateScene(scene, path); !st) return st;
    AssetWriter w;
    w.addChunk(chunk::Scene, encodeScene(scene), zstdLevel);
    std::string meta = sceneMeta(scene);
    w.addChunk(chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(meta.data()), meta.size()), zstdLevel);
    return w.write(path);
  } catch (const std::bad_alloc&) {
    return makeError(path, "out of memory encoding the scene");
  }
}

Result<Scene> loadScene(const std::string& path) {
  Result<AssetReader> reader = AssetReader::open(path);
  if (!reader) return reader.error();
  Result<std::vector<uint8_t>> bytes = reader->readChunk(chunk::Scene);
  if (!bytes) return bytes.error();
  Result<Scene> scene = decodeScene(*bytes, path);
  if (!scene) return scene;
  if (std::optional<size_t> meta = reader->find(chunk::Meta)) {
    Result<std::vector<uint8_t>> metaBytes = reader->readChunk(*meta);
    if (!metaBytes) return metaBytes.error();
    if (Status st = checkMeta(*metaBytes, *scene, path); !st) return st.error();
  }
  return scene;
}

} // namespace mirage::asset
