// glTF 2.0 import through tinygltf (JSON, buffers) with our own accessor reading (strided, normalized, quantized
// and sparse accessors), image decoding (decodeImageProblem), node flattening and material conversion. The file's
// layout is checked, and EXT_meshopt_compression files rewritten to plain GLB in memory, first (gltf_prepare.cpp).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <tiny_gltf.h>

#include "gltf_prepare.h"
#include "import_internal.h"

namespace mirage::io {
namespace {

namespace tg = tinygltf;

// Deepest node hierarchy accepted (recursion depth of the flattening).
constexpr int kMaxNodeDepth = 1024;

// tinygltf joins messages with newlines and quotes input in them; our errors are one line of printable text.
std::string oneLine(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (size_t p; (p = s.find('\n')) != std::string::npos;) s.replace(p, 1, "; ");
  return escapeInput(s, 240);
}

// Skips image decoding when textures are not wanted (the images keep no pixels).
bool skipImage(tg::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// Decodes glTF images through the importers' one image decoder (same size limit and wording as OBJ textures).
bool decodeGltfImage(tg::Image* image, const int index, std::string* err, std::string*, int, int,
                     const unsigned char* bytes, int size, void*) {
  Texture t;
  if (std::string problem = detail::decodeImageProblem(bytes, size_t(std::max(size, 0)), t); !problem.empty()) {
    *err += fmt::format("image {}: {}", index, problem);
    return false;
  }
  image->width = int(t.width);
  image->height = int(t.height);
  image->component = 4;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image = std::move(t.rgba8);
  return true;
}

class GltfConverter {
public:
  GltfConverter(const tg::Model& model, std::string file, const ImportOptions& options)
      : m_(model), file_(std::move(file)), options_(options) {}

  Result<Scene> run() {
    for (size_t i = 0; i < m_.materials.size(); ++i) scene_.materials.push_back(material(m_.materials[i]));
    std::vector<int> roots;
    if (m_.defaultScene >= 0 && size_t(m_.defaultScene) < m_.scenes.size())
      roots = m_.scenes[m_.defaultScene].nodes;
    else if (!m_.scenes.empty())
      roots = m_.scenes[0].nodes;
    else { // no scenes: every node that is nobody's child
      std::vector<bool> child(m_.nodes.size(), false);
      for (const tg::Node& n : m_.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < child.size()) child[c] = true;
      for (size_t i = 0; i < m_.nodes.size(); ++i)
        if (!child[i]) roots.push_back(int(i));
    }
    std::vector<bool> onPath(m_.nodes.size(), false);
    for (int r : roots)
      if (Status s = visit(r, glm::mat4(1.0f), onPath, 1); !s) return s.error();
    if (Status s = detail::finalizeScene(scene_, file_, options_); !s) return s.error();
    return std::move(scene_);
  }

private:
  Status fail(const std::string& problem) const { return makeError(file_, problem); }

  static glm::mat4 localMatrix(const tg::Node& n) {
    if (n.matrix.size() == 16) {
      float f[16];
      for (int i = 0; i < 16; ++i) f[i] = float(n.matrix[i]);
      return glm::make_mat4(f); // glTF and glm are both column-major
    }
    glm::mat4 t(1.0f), r(1.0f), s(1.0f);
    if (n.translation.size() == 3)
      t = glm::translate(glm::mat4(1.0f), glm::vec3(n.translation[0], n.translation[1], n.translation[2]));
    if (n.rotation.size() == 4) // glTF stores x, y, z, w; glm::quat's constructor takes w first
      r = glm::mat4_cast(
          glm::quat(float(n.rotation[3]), float(n.rotation[0]), float(n.rotation[1]), float(n.rotation[2])));
    if (n.scale.size() == 3) s = glm::scale(glm::mat4(1.0f), glm::vec3(n.scale[0], n.scale[1], n.scale[2]));
    return t * r * s;
  }

  Status visit(int index, const glm::mat4& parent, std::vector<bool>& onPath, int depth) {
    if (index < 0 || size_t(index) >= m_.nodes.size()) return fail(fmt::format("node index {} out of range", index));
    if (onPath[index]) return fail(fmt::format("node {} is part of a cycle", index));
    if (depth > kMaxNodeDepth)
      return fail(fmt::format("node hierarchy deeper than {} levels (at node {})", kMaxNodeDepth, index));
    // glTF nodes have one parent; a file that shares subtrees could otherwise expand exponentially.
    if (++visits_ > 4 * m_.nodes.size() + 1000000) return fail("node graph too large (nodes with several parents)");
    const tg::Node& node = m_.nodes[index];
    glm::mat4 world = parent * localMatrix(node);
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= m_.meshes.size()) return fail(fmt::format("node {}: mesh index out of range", index));
      const tg::Mesh& gm = m_.meshes[node.mesh];
      for (size_t p = 0; p < gm.primitives.size(); ++p) {
        auto key = std::make_pair(node.mesh, int(p));
        auto it = meshOf_.find(key);
        if (it == meshOf_.end()) {
          Mesh mesh;
          Status s = primitive(gm, gm.primitives[p], mesh);
          if (!s) return s;
          int id = -1; // non-triangle and empty primitives are skipped
          if (!mesh.indices.empty()) {
            id = int(scene_.meshes.size());
            scene_.meshes.push_back(std::move(mesh));
          }
          it = meshOf_.emplace(key, id).first;
        }
        if (it->second >= 0) scene_.instances.push_back(Instance{uint32_t(it->second), world});
      }
    }
    pointLight(node, world);
    onPath[index] = true;
    for (int c : node.children)
      if (Status s = visit(c, world, onPath, depth + 1); !s) return s;
    onPath[index] = false;
    return Ok{};
  }

  // Read an accessor as `count * comps` floats (ints unnormalized as values; normalized ints mapped to [0,1]
  // or [-1,1] per the glTF spec), applying sparse substitution.
  Status readFloats(int index, std::vector<float>& out, int& comps) const {
    if (index < 0 || size_t(index) >= m_.accessors.size()) return fail(fmt::format("accessor {} out of range", index));
    const tg::Accessor& a = m_.accessors[index];
    comps = tg::GetNumComponentsInType(uint32_t(a.type));
    int csize = tg::GetComponentSizeInBytes(uint32_t(a.componentType));
    if (comps <= 0 || csize <= 0) return fail(fmt::format("accessor {}: bad type", index));
    // Without a bufferView only sparse values fill the array; cap its size so a hostile count cannot exhaust memory.
    if (a.bufferView < 0 && a.count > (size_t(1) << 26))
      return fail(fmt::format("accessor {}: implausible count without a bufferView", index));
    auto decode = [&](const uint8_t* src, float* dst) {
      for (int c = 0; c < comps; ++c, src += csize) {
        float v;
        switch (a.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT:
          std::memcpy(&v, src, 4);
          break;
        case TINYGLTF_COMPONENT_TYPE_BYTE:
          v = a.normalized ? std::max(int8_t(*src) / 127.0f, -1.0f) : int8_t(*src);
          break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
          v = a.normalized ? *src / 255.0f : *src;
          break;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          int16_t s;
          std::memcpy(&s, src, 2);
          v = a.normalized ? std::max(s / 32767.0f, -1.0f) : s;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          uint16_t s;
          std::memcpy(&s, src, 2);
          v = a.normalized ? s / 65535.0f : s;
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
          uint32_t s;
          std::memcpy(&s, src, 4);
          v = float(s);
          break;
        }
        default:
          v = 0.0f;
        }
        dst[c] = v;
      }
    };
    const size_t elem = size_t(comps) * size_t(csize);
    if (a.bufferView < 0) out.assign(a.count * size_t(comps), 0.0f);
    if (a.bufferView >= 0) { // no bufferView means all zeros (plus sparse values)
      const uint8_t* base;
      size_t stride;
      if (Status s = viewData(a.bufferView, a.byteOffset, a.count, elem, base, stride); !s) return s;
      out.resize(a.count * size_t(comps)); // sized only once the view is known to hold the data
      for (size_t i = 0; i < a.count; ++i) decode(base + i * stride, &out[i * comps]);
    }
    if (a.sparse.isSparse) {
      size_t n = size_t(a.sparse.count);
      std::vector<uint32_t> idx;
      if (Status s = readIndexView(a.sparse.indices.bufferView, a.sparse.indices.byteOffset,
                                   a.sparse.indices.componentType, n, idx);
          !s)
        return s;
      const uint8_t* vals;
      size_t vstride;
      if (Status s = viewData(a.sparse.values.bufferView, a.sparse.values.byteOffset, n, elem, vals, vstride); !s)
        return s;
      for (size_t k = 0; k < n; ++k) {
        if (idx[k] >= a.count) return fail(fmt::format("accessor {}: sparse index out of range", index));
        decode(vals + k * elem, &out[size_t(idx[k]) * comps]);
      }
    }
    return Ok{};
  }

  // Bounds-checked pointer and stride for `count` elements of `elem` bytes in a bufferView.
  Status viewData(int viewIndex, size_t offset, size_t count, size_t elem, const uint8_t*& base, size_t& stride) const {
    if (viewIndex < 0 || size_t(viewIndex) >= m_.bufferViews.size())
      return fail(fmt::format("bufferView {} out of range", viewIndex));
    const tg::BufferView& v = m_.bufferViews[viewIndex];
    if (v.buffer < 0 || size_t(v.buffer) >= m_.buffers.size()) return fail("bufferView refers to a missing buffer");
    const std::vector<unsigned char>& buf = m_.buffers[v.buffer].data;
    stride = v.byteStride ? v.byteStride : elem;
    if (count > 0 && count - 1 > v.byteLength / stride) // checked first so the product below cannot overflow
      return fail(fmt::format("bufferView {}: accessor data runs past the buffer", viewIndex));
    size_t need = count ? offset + (count - 1) * stride + elem : 0;
    if (need > v.byteLength || v.byteOffset + v.byteLength > buf.size())
      return fail(fmt::format("bufferView {}: accessor data runs past the buffer", viewIndex));
    base = buf.data() + v.byteOffset + offset;
    return Ok{};
  }

  Status readIndexView(int view, size_t offset, int componentType, size_t count, std::vector<uint32_t>& out) const {
    int csize = tg::GetComponentSizeInBytes(uint32_t(componentType));
    if (csize != 1 && csize != 2 && csize != 4) return fail("bad index component type");
    const uint8_t* base;
    size_t stride;
    if (Status s = viewData(view, offset, count, size_t(csize), base, stride); !s) return s;
    out.resize(count);
    for (size_t i = 0; i < count; ++i) {
      const uint8_t* p = base + i * stride;
      if (csize == 1)
        out[i] = *p;
      else if (csize == 2) {
        uint16_t v;
        std::memcpy(&v, p, 2);
        out[i] = v;
      } else
        std::memcpy(&out[i], p, 4);
    }
    return Ok{};
  }

  template <class V>
  Status attribute(const tg::Primitive& prim, const char* name, size_t count, int minComps, std::vector<V>& dst) const {
    auto it = prim.attributes.find(name);
    if (it == prim.attributes.end()) return Ok{};
    std::vector<float> f;
    int comps = 0;
    if (Status s = readFloats(it->second, f, comps); !s) return s;
    if (comps < minComps || f.size() / size_t(comps) != count)
      return fail(fmt::format("attribute {} has a bad type or count", name));
    dst.resize(count);
    for (size_t i = 0; i < count; ++i) {
      V v(1.0f); // COLOR_0 as VEC3 gets alpha 1
      for (int c = 0; c < std::min<int>(comps, V::length()); ++c) v[c] = f[i * comps + c];
      dst[i] = v;
    }
    return Ok{};
  }

  Status primitive(const tg::Mesh& gm, const tg::Primitive& prim, Mesh& mesh) {
    int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      return Ok{}; // points and lines have no surface
    auto pos = prim.attributes.find("POSITION");
    if (pos == prim.attributes.end())
      return fail(fmt::format("mesh {}: primitive without POSITION", quoteInput(gm.name)));
    mesh.name = gm.name;
    if (Status s = attribute(prim, "POSITION", m_.accessors.at(pos->second).count, 3, mesh.positions); !s) return s;
    const size_t n = mesh.positions.size();
    if (Status s = attribute(prim, "NORMAL", n, 3, mesh.normals); !s) return s;
    if (Status s = attribute(prim, "TANGENT", n, 4, mesh.tangents); !s) return s;
    if (Status s = attribute(prim, "TEXCOORD_0", n, 2, mesh.uv0); !s) return s;
    if (Status s = attribute(prim, "COLOR_0", n, 3, mesh.colors); !s) return s;

    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
      if (size_t(prim.indices) >= m_.accessors.size()) return fail("index accessor out of range");
      const tg::Accessor& a = m_.accessors[prim.indices];
      if (a.type != TINYGLTF_TYPE_SCALAR || a.sparse.isSparse) return fail("unsupported index accessor");
      if (Status s = readIndexView(a.bufferView, a.byteOffset, a.componentType, a.count, idx); !s) return s;
    } else {
      idx.resize(n);
      for (size_t i = 0; i < n; ++i) idx[i] = uint32_t(i);
    }
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      idx.resize(idx.size() / 3 * 3); // a stray partial triangle carries no surface
      mesh.indices = std::move(idx);
    } else {
      for (size_t i = 0; i + 2 < idx.size(); ++i) {
        if (mode == TINYGLTF_MODE_TRIANGLE_FAN)
          mesh.indices.insert(mesh.indices.end(), {idx[0], idx[i + 1], idx[i + 2]});
        else if (i % 2 == 0)
          mesh.indices.insert(mesh.indices.end(), {idx[i], idx[i + 1], idx[i + 2]});
        else
          mesh.indices.insert(mesh.indices.end(), {idx[i + 1], idx[i], idx[i + 2]}); // keep winding
      }
    }
    if (prim.material >= 0 && size_t(prim.material) < scene_.materials.size()) {
      mesh.material = uint32_t(prim.material);
    } else {
      if (defaultMaterial_ < 0) { // the glTF default material: white, metallic 1, roughness 1
        defaultMaterial_ = int(scene_.materials.size());
        scene_.materials.push_back(Material{});
        scene_.materials.back().name = "default";
      }
      mesh.material = uint32_t(defaultMaterial_);
    }
    return Ok{};
  }

  // A glTF texture as a Scene texture. Images referenced both as colour (sRGB) and as data (linear) are
  // duplicated, one copy per interpretation, so every Texture has a single correct `srgb` flag.
  int texture(int textureIndex, bool srgb) {
    if (!options_.loadTextures || textureIndex < 0 || size_t(textureIndex) >= m_.textures.size()) return -1;
    int source = m_.textures[textureIndex].source;
    if (source < 0 || size_t(source) >= m_.images.size()) return -1;
    auto key = std::make_pair(source, srgb);
    if (auto it = textureOf_.find(key); it != textureOf_.end()) return it->second;
    const tg::Image& img = m_.images[source];
    int id = -1;
    size_t pixels = size_t(img.width) * size_t(img.height);
    int bytesPer = img.bits == 16 ? 2 : 1;
    if (img.width > 0 && img.height > 0 && img.component >= 1 && img.component <= 4 &&
        img.image.size() >= pixels * size_t(img.component * bytesPer)) {
      Texture t;
      t.name = !img.uri.empty() ? img.uri : (!img.name.empty() ? img.name : fmt::format("embedded #{}", source));
      t.width = uint32_t(img.width);
      t.height = uint32_t(img.height);
      t.srgb = srgb;
      t.rgba8.resize(pixels * 4);
      const int c = img.component;
      for (size_t i = 0; i < pixels; ++i) {
        uint8_t v[4] = {0, 0, 0, 255};
        for (int k = 0; k < c; ++k) // 16-bit channels keep their high byte (little endian storage)
          v[k] = bytesPer == 2 ? img.image[(i * c + k) * 2 + 1] : img.image[i * c + k];
        if (c <= 2) { // grey (+alpha) expands to RGB
          if (c == 2) v[3] = v[1];
          v[1] = v[2] = v[0];
        }
        std::memcpy(&t.rgba8[i * 4], v, 4);
      }
      id = int(scene_.textures.size());
      scene_.textures.push_back(std::move(t));
    }
    textureOf_[key] = id;
    return id;
  }

  Material material(const tg::Material& g) {
    Material m;
    m.name = g.name;
    const auto& pbr = g.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() == 4)
      m.baseColorFactor =
          glm::vec4(pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2], pbr.baseColorFactor[3]);
    m.metallicFactor = float(pbr.metallicFactor);
    m.roughnessFactor = float(pbr.roughnessFactor);
    if (g.emissiveFactor.size() == 3)
      m.emissiveFactor = glm::vec3(g.emissiveFactor[0], g.emissiveFactor[1], g.emissiveFactor[2]);
    m.normalScale = float(g.normalTexture.scale);
    m.occlusionStrength = float(g.occlusionTexture.strength);
    m.alphaCutoff = float(g.alphaCutoff);
    m.alphaMode = g.alphaMode == "BLEND"  ? AlphaMode::Blend
                  : g.alphaMode == "MASK" ? AlphaMode::Mask
                                          : AlphaMode::Opaque;
    m.doubleSided = g.doubleSided;
    m.baseColorTexture = texture(pbr.baseColorTexture.index, true);
    m.metallicRoughnessTexture = texture(pbr.metallicRoughnessTexture.index, false);
    m.normalTexture = texture(g.normalTexture.index, false);
    m.occlusionTexture = texture(g.occlusionTexture.index, false);
    m.emissiveTexture = texture(g.emissiveTexture.index, true);
    m.uv[kMapBaseColor] = uvTransform(pbr.baseColorTexture);
    m.uv[kMapMetallicRoughness] = uvTransform(pbr.metallicRoughnessTexture);
    m.uv[kMapNormal] = uvTransform(g.normalTexture);
    m.uv[kMapOcclusion] = uvTransform(g.occlusionTexture);
    m.uv[kMapEmissive] = uvTransform(g.emissiveTexture);
    return m;
  }

  // A KHR_lights_punctual point light on the node, at its world origin. Intensity (candela) is taken
  // as the light's intensity; without a range the radius is where its irradiance intensity / d^2
  // falls to 0.001. Spot and directional lights, and malformed ones, are skipped (the key light stays).
  void pointLight(const tg::Node& node, const glm::mat4& world) {
    auto it = node.extensions.find("KHR_lights_punctual");
    if (it == node.extensions.end() || !it->second.IsObject()) return;
    const tg::Value& index = it->second.Get("light");
    if (!index.IsInt() || index.GetNumberAsInt() < 0 || size_t(index.GetNumberAsInt()) >= m_.lights.size()) return;
    const tg::Light& g = m_.lights[size_t(index.GetNumberAsInt())];
    PointLight l;
    l.position = glm::vec3(world[3]);
    l.intensity = float(g.intensity);
    if (g.color.size() == 3) l.color = glm::vec3(float(g.color[0]), float(g.color[1]), float(g.color[2]));
    l.radius = g.range > 0.0 ? float(g.range) : std::sqrt(l.intensity * 1000.0f);
    auto finite3 = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
    bool valid = g.type == "point" && l.intensity > 0.0f && std::isfinite(l.intensity) && l.radius > 0.0f &&
                 std::isfinite(l.radius) && finite3(l.position) && finite3(l.color) &&
                 glm::all(glm::greaterThanEqual(l.color, glm::vec3(0.0f)));
    if (valid) scene_.lights.push_back(l);
  }

  // KHR_texture_transform of a textureInfo: offset, rotation, scale (a texCoord override is moot:
  // meshes keep one UV set). Malformed or non-finite values leave the identity.
  template <class Info> static UvTransform uvTransform(const Info& info) {
    UvTransform t;
    auto it = info.extensions.find("KHR_texture_transform");
    if (it == info.extensions.end() || !it->second.IsObject()) return t;
    const tg::Value& v = it->second;
    auto number = [](const tg::Value& n, float& out) {
      if (!n.IsNumber()) return false;
      float f = float(n.GetNumberAsDouble());
      if (!std::isfinite(f)) return false;
      out = f;
      return true;
    };
    auto vec2 = [&](const char* key, glm::vec2& out) {
      const tg::Value& a = v.Get(key);
      glm::vec2 r;
      if (a.IsArray() && a.ArrayLen() == 2 && number(a.Get(0), r.x) && number(a.Get(1), r.y)) out = r;
    };
    vec2("offset", t.offset);
    vec2("scale", t.scale);
    number(v.Get("rotation"), t.rotation);
    return t;
  }

  const tg::Model& m_;
  std::string file_;
  ImportOptions options_;
  Scene scene_;
  int defaultMaterial_ = -1;
  size_t visits_ = 0;
  std::map<std::pair<int, int>, int> meshOf_;
  std::map<std::pair<int, bool>, int> textureOf_;
};

} // namespace

Result<Scene> importGltf(const std::filesystem::path& path, const ImportOptions& options) {
  const std::string file = detail::displayName(path);
  auto bytes = detail::readFile(path);
  if (!bytes) return bytes.error();
  const std::string baseDir = path.parent_path().string();
  auto decoded = detail::prepareGltf(*bytes, path.parent_path(), options.loadTextures, file);
  if (!decoded) return decoded.error();

  tg::TinyGLTF loader;
  if (options.loadTextures)
    loader.SetImageLoader(decodeGltfImage, nullptr);
  else
    loader.SetImageLoader(skipImage, nullptr);
  tg::Model model;
  std::string err, warn;
  bool ok;
  try { // tinygltf's JSON parser may throw on hostile input; nothing may escape our API
    if (decoded->has_value()) {
      const std::vector<uint8_t>& glb = **decoded;
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), unsigned(glb.size()), baseDir);
    } else if (bytes->size() >= 4 && std::memcmp(bytes->data(), "glTF", 4) == 0) {
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes->data()),
                                       unsigned(bytes->size()), baseDir);
    } else {
      ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes->data(), unsigned(bytes->size()), baseDir);
    }
  } catch (const std::exception& e) {
    return makeError(file, fmt::format("glTF parse error: {}", escapeInput(e.what(), 240)));
  }
  if (!ok) return makeError(file, oneLine(err.empty() ? "cannot parse glTF" : err));
  // Geometry in an extension we do not decode (Draco, ...) would import as garbage: refuse it up front. Material
  // and texture extensions degrade gracefully (the core material stays valid), so they are accepted.
  for (const std::string& ext : model.extensionsRequired) {
    bool ignorable = ext == "KHR_mesh_quantization" || ext == "KHR_texture_transform" || ext == "KHR_lights_punctual" ||
                     ext.rfind("KHR_materials_", 0) == 0 || ext == "KHR_texture_basisu" || ext == "EXT_texture_webp";
    if (!ignorable) return makeError(file, fmt::format("requires unsupported glTF extension {}", quoteInput(ext)));
  }
  bytes->clear();
  bytes->shrink_to_fit();
  try {
    GltfConverter converter(model, file, options);
    return converter.run();
  } catch (const std::exception& e) { // e.g. bad_alloc on absurd sizes: still one Error line, never a throw
    return makeError(file, fmt::format("import failed: {}", escapeInput(e.what(), 240)));
  }
}

} // namespace mirage::io
