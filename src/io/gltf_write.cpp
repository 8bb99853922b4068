// GLB writer. Written directly with nlohmann_json rather than through tinygltf's writer: no copy of
// the (possibly multi-GB) vertex data into tinygltf's model, and full control of the layout.
#include "mirage/io/gltf_write.h"

#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <stb/stb_image_write.h>

#include "mirage/io/image_io.h"

namespace mirage::io {

namespace {

using nlohmann::json;

constexpr int kFloat = 5126, kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

class BinBuilder {
public:
  // Appends bytes 4-byte aligned (every glTF accessor component here is 4 bytes) and returns the
  // index of a new bufferView covering them.
  int view(const void* data, size_t size, int target, json& views) {
    bin_.resize((bin_.size() + 3) & ~size_t(3), 0);
    json v = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) v["target"] = target;
    const auto* p = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), p, p + size);
    views.push_back(std::move(v));
    return int(views.size()) - 1;
  }
  std::vector<uint8_t>& bytes() { return bin_; }

private:
  std::vector<uint8_t> bin_;
};

template <class V> int accessor(BinBuilder& bin, json& doc, const std::vector<V>& data, const char* type, int target) {
  int view = bin.view(data.data(), data.size() * sizeof(V), target, doc["bufferViews"]);
  doc["accessors"].push_back({{"bufferView", view}, {"componentType", kFloat}, {"count", data.size()}, {"type", type}});
  return int(doc["accessors"].size()) - 1;
}

json textureRef(int32_t index, size_t textureCount) {
  return index >= 0 && size_t(index) < textureCount ? json{{"index", index}} : json();
}

json materialJson(const Material& m, size_t textureCount) {
  json pbr = {{"baseColorFactor", {m.baseColorFactor.r, m.baseColorFactor.g, m.baseColorFactor.b, m.baseColorFactor.a}},
              {"metallicFactor", m.metallicFactor},
              {"roughnessFactor", m.roughnessFactor}};
  if (json t = textureRef(m.baseColorTexture, textureCount); !t.is_null()) pbr["baseColorTexture"] = t;
  if (json t = textureRef(m.metallicRoughnessTexture, textureCount); !t.is_null()) pbr["metallicRoughnessTexture"] = t;
  json out = {{"name", m.name}, {"pbrMetallicRoughness", pbr}, {"doubleSided", m.doubleSided}};
  if (json t = textureRef(m.normalTexture, textureCount); !t.is_null()) {
    t["scale"] = m.normalScale;
    out["normalTexture"] = t;
  }
  if (json t = textureRef(m.occlusionTexture, textureCount); !t.is_null()) {
    t["strength"] = m.occlusionStrength;
    out["occlusionTexture"] = t;
  }
  if (json t = textureRef(m.emissiveTexture, textureCount); !t.is_null()) out["emissiveTexture"] = t;
  out["emissiveFactor"] = {m.emissiveFactor.r, m.emissiveFactor.g, m.emissiveFactor.b};
  switch (m.alphaMode) {
  case AlphaMode::Opaque:
    out["alphaMode"] = "OPAQUE";
    break;
  case AlphaMode::Mask:
    out["alphaMode"] = "MASK";
    out["alphaCutoff"] = m.alphaCutoff; // only meaningful (and only allowed by validators) for MASK
    break;
  case AlphaMode::Blend:
    out["alphaMode"] = "BLEND";
    break;
  }
  return out;
}

bool isIdentity(const glm::mat4& m) { return m == glm::mat4(1.0f); }

} // namespace

Status writeGlb(const Scene& scene, const std::filesystem::path& path) {
  const std::string file = path.string();
  json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", "mirage"}};
  doc["bufferViews"] = json::array();
  doc["accessors"] = json::array();
  BinBuilder bin;

  // Meshes. glTF forbids empty accessors, so a mesh without triangles becomes no glTF mesh and the
  // nodes of its instances carry no "mesh".
  std::vector<int> gltfMesh(scene.meshes.size(), -1);
  json meshes = json::array();
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& m = scene.meshes[i];
    if (m.positions.empty() || m.indices.size() < 3) continue;
    if (m.positions.size() > std::numeric_limits<uint32_t>::max())
      return makeError(file, "mesh '" + m.name + "' has too many vertices for glTF");
    for (uint32_t index : m.indices)
      if (index >= m.positions.size()) return makeError(file, "mesh '" + m.name + "' has an out-of-range index");
    json attributes;
    attributes["POSITION"] = accessor(bin, doc, m.positions, "VEC3", kArrayBuffer);
    Bounds b; // exact min/max of the data (the spec requires them for POSITION)
    for (const glm::vec3& p : m.positions) b.add(p);
    doc["accessors"].back()["min"] = {b.min.x, b.min.y, b.min.z};
    doc["accessors"].back()["max"] = {b.max.x, b.max.y, b.max.z};
    if (m.normals.size() == m.positions.size())
      attributes["NORMAL"] = accessor(bin, doc, m.normals, "VEC3", kArrayBuffer);
    if (m.tangents.size() == m.positions.size())
      attributes["TANGENT"] = accessor(bin, doc, m.tangents, "VEC4", kArrayBuffer);
    if (m.uv0.size() == m.positions.size()) attributes["TEXCOORD_0"] = accessor(bin, doc, m.uv0, "VEC2", kArrayBuffer);
    if (m.colors.size() == m.positions.size())
      attributes["COLOR_0"] = accessor(bin, doc, m.colors, "VEC4", kArrayBuffer);
    size_t indexCount = m.indices.size() / 3 * 3;
    int view = bin.view(m.indices.data(), indexCount * 4, kElementArrayBuffer, doc["bufferViews"]);
    doc["accessors"].push_back(
        {{"bufferView", view}, {"componentType", kUnsignedInt}, {"count", indexCount}, {"type", "SCALAR"}});
    json primitive = {{"attributes", attributes}, {"indices", int(doc["accessors"].size()) - 1}, {"mode", 4}};
    if (m.material < scene.materials.size()) primitive["material"] = m.material;
    meshes.push_back({{"name", m.name}, {"primitives", json::array({primitive})}});
    gltfMesh[i] = int(meshes.size()) - 1;
  }
  if (!meshes.empty()) doc["meshes"] = std::move(meshes);

  json nodes = json::array(), roots = json::array();
  for (const Instance& inst : scene.instances) {
    json node = json::object();
    if (inst.mesh < gltfMesh.size() && gltfMesh[inst.mesh] >= 0) node["mesh"] = gltfMesh[inst.mesh];
    if (!isIdentity(inst.transform)) {
      json matrix = json::array();
      for (int c = 0; c < 4; ++c) // glm is column-major, as glTF's matrix is
        for (int r = 0; r < 4; ++r) matrix.push_back(inst.transform[c][r]);
      node["matrix"] = matrix;
    }
    nodes.push_back(std::move(node));
    roots.push_back(nodes.size() - 1);
  }
  if (!nodes.empty()) doc["nodes"] = std::move(nodes);
  doc["scenes"] = json::array({{{"nodes", roots}}});
  doc["scene"] = 0;

  if (!scene.materials.empty()) {
    json materials = json::array();
    for (const Material& m : scene.materials) materials.push_back(materialJson(m, scene.textures.size()));
    doc["materials"] = std::move(materials);
  }
  if (!scene.textures.empty()) {
    json images = json::array(), textures = json::array();
    for (size_t i = 0; i < scene.textures.size(); ++i) {
      const Texture& t = scene.textures[i];
      if (t.width == 0 || t.height == 0 || t.rgba8.size() != size_t(t.width) * t.height * 4)
        return makeError(file, "texture '" + t.name + "' has no valid RGBA8 pixels");
      std::vector<uint8_t> png;
      auto sink = [](void* context, void* data, int size) {
        auto* out = static_cast<std::vector<uint8_t>*>(context);
        out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
      };
      if (!stbi_write_png_to_func(sink, &png, int(t.width), int(t.height), 4, t.rgba8.data(), int(t.width * 4)))
        return makeError(file, "PNG encoding of texture '" + t.name + "' failed");
      int view = bin.view(png.data(), png.size(), 0, doc["bufferViews"]);
      images.push_back({{"name", t.name}, {"mimeType", "image/png"}, {"bufferView", view}});
      textures.push_back({{"source", i}, {"sampler", 0}});
    }
    doc["images"] = std::move(images);
    doc["textures"] = std::move(textures);
    // Trilinear filtering, repeat wrapping: what the generators and importers assume.
    doc["samplers"] = json::array({{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 10497}, {"wrapT", 10497}}});
  }

  std::vector<uint8_t>& binBytes = bin.bytes();
  binBytes.resize((binBytes.size() + 3) & ~size_t(3), 0);
  if (!binBytes.empty()) doc["buffers"] = json::array({{{"byteLength", binBytes.size()}}});
  if (doc["bufferViews"].empty()) doc.erase("bufferViews");
  if (doc["accessors"].empty()) doc.erase("accessors");

  std::string text = doc.dump();
  text.resize((text.size() + 3) & ~size_t(3), ' '); // JSON chunk is padded with spaces
  const uint64_t total = 12 + 8 + text.size() + (binBytes.empty() ? 0 : 8 + binBytes.size());
  if (total > std::numeric_limits<uint32_t>::max()) return makeError(file, "scene too large for GLB (over 4 GiB)");

  // The 28 header bytes and the JSON go in one small buffer; the binary chunk is written from where
  // it already lies, so a multi-GB scene is not copied once more.
  std::vector<uint8_t> out;
  out.reserve(28 + text.size());
  auto put32 = [&](uint32_t v) {
    uint8_t b[4];
    std::memcpy(b, &v, 4);
    out.insert(out.end(), b, b + 4);
  };
  put32(0x46546C67); // "glTF"
  put32(2);
  put32(uint32_t(total));
  put32(uint32_t(text.size()));
  put32(0x4E4F534A); // "JSON"
  out.insert(out.end(), text.begin(), text.end());
  if (!binBytes.empty()) {
    put32(uint32_t(binBytes.size()));
    put32(0x004E4942); // "BIN\0"
  }
  const std::span<const uint8_t> parts[2] = {out, binBytes};
  return writeFileAtomic(path, parts);
}

} // namespace mirage::io
