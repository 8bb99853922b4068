// Wavefront OBJ + MTL import. The whole file is read once and scanned in place with std::from_chars; faces are
// fan-triangulated and split into one Mesh per material (usemtl), with vertices shared per mesh by their
// (position, uv, normal) index triple so the mesh keeps the file's topology. Files the OBJ names (mtllib, texture
// maps) must exist and decode, as a glTF's buffers and images must: a missing one is an error naming it, never a
// silently untextured import (ImportOptions::loadTextures = false skips texture maps altogether).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include <fmt/format.h>

#include "import_internal.h"

namespace mirage::io {
namespace {

struct Cursor {
  const char* p;
  const char* end;
  void skipSpace() {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
  }
  bool atLineEnd() {
    skipSpace();
    return p >= end || *p == '\n' || *p == '#';
  }
  void skipLine() {
    const void* nl = std::memchr(p, '\n', size_t(end - p));
    p = nl ? static_cast<const char*>(nl) + 1 : end;
  }
  std::string_view word() {
    skipSpace();
    const char* s = p;
    while (p < end && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n') ++p;
    return {s, size_t(p - s)};
  }
  std::string_view restOfLine() {
    skipSpace();
    const char* s = p;
    while (p < end && *p != '\n') ++p;
    const char* e = p;
    while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r')) --e;
    return {s, size_t(e - s)};
  }
  bool number(float& v) {
    skipSpace();
    if (p < end && *p == '+') ++p; // from_chars rejects an explicit plus sign
    auto [q, ec] = std::from_chars(p, end, v);
    if (ec == std::errc::result_out_of_range) { // denormals and huge values: keep going, validation catches Inf
      v = 0.0f;
      while (q < end && *q != ' ' && *q != '\t' && *q != '\r' && *q != '\n') ++q;
    } else if (ec != std::errc()) {
      return false;
    }
    p = q;
    return true;
  }
};

struct Corner {
  uint32_t v, t, n; // 0-based; ~0u when absent
  bool operator==(const Corner&) const = default;
};
struct CornerHash {
  size_t operator()(const Corner& c) const {
    uint64_t h = uint64_t(c.v) * 0x9E3779B97F4A7C15ull ^ (uint64_t(c.t) * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t(c.n) * 0x165667B19E3779F9ull);
    return size_t(h ^ (h >> 29));
  }
};

struct Group {
  Mesh mesh;
  std::unordered_map<Corner, uint32_t, CornerHash> vertexOf;
};

class ObjParser {
public:
  ObjParser(const std::filesystem::path& path, const ImportOptions& options)
      : path_(path), file_(detail::displayName(path)), options_(options) {}

  Result<Scene> run() {
    auto data = detail::readFile(path_);
    if (!data) return data.error();
    const std::vector<char>& buf = *data;
    Cursor c{buf.data(), buf.data() + buf.size()};
    size_t line = 0;
    while (c.p < c.end) {
      ++line;
      c.skipSpace();
      std::string_view kw = c.word();
      Status s = Ok{};
      if (kw == "v")
        s = vertex(c, line);
      else if (kw == "vt")
        s = texcoord(c, line);
      else if (kw == "vn")
        s = normal(c, line);
      else if (kw == "f")
        s = face(c, line);
      else if (kw == "usemtl")
        current_ = groupFor(std::string(c.restOfLine()));
      else if (kw == "mtllib")
        s = mtllib(std::string(c.restOfLine()));
      if (!s) return s.error();
      c.skipLine();
    }
    for (Group& g : groups_)
      if (!g.mesh.indices.empty()) scene_.meshes.push_back(std::move(g.mesh));
    if (Status s = detail::finalizeScene(scene_, file_, options_); !s) return s.error();
    return std::move(scene_);
  }

private:
  Status fail(size_t line, const std::string& problem) const {
    return makeError(file_, fmt::format("line {}: {}", line, problem));
  }

  Status vertex(Cursor& c, size_t line) {
    glm::vec3 v;
    if (!c.number(v.x) || !c.number(v.y) || !c.number(v.z)) return fail(line, "bad vertex position");
    positions_.push_back(v);
    // Optional "v x y z r g b" vertex colours (a common extension).
    glm::vec3 rgb;
    if (!c.atLineEnd() && c.number(rgb.r) && c.number(rgb.g) && c.number(rgb.b)) {
      colors_.resize(positions_.size() - 1, glm::vec4(1.0f));
      colors_.push_back(glm::vec4(rgb, 1.0f));
    } else if (!colors_.empty()) {
      colors_.push_back(glm::vec4(1.0f)); // keep colours aligned with positions once any vertex has one
    }
    return Ok{};
  }
  Status texcoord(Cursor& c, size_t line) {
    glm::vec2 t;
    if (!c.number(t.x)) return fail(line, "bad texture coordinate");
    if (!c.atLineEnd() && !c.number(t.y)) return fail(line, "bad texture coordinate");
    // OBJ puts v = 0 at the bottom; glTF/Vulkan sample with v = 0 at the top.
    uvs_.push_back(glm::vec2(t.x, 1.0f - t.y));
    return Ok{};
  }
  Status normal(Cursor& c, size_t line) {
    glm::vec3 n;
    if (!c.number(n.x) || !c.number(n.y) || !c.number(n.z)) return fail(line, "bad normal");
    normals_.push_back(n);
    return Ok{};
  }

  // Resolve a 1-based (or negative, relative) OBJ index against the count defined so far.
  bool resolve(long long i, size_t count, uint32_t& out) const {
    if (i > 0 && size_t(i) <= count)
      out = uint32_t(i - 1);
    else if (i < 0 && size_t(-i) <= count)
      out = uint32_t(static_cast<long long>(count) + i);
    else
      return false;
    return true;
  }

  Status face(Cursor& c, size_t line) {
    poly_.clear();
    while (!c.atLineEnd()) {
      long long idx[3] = {0, 0, 0};
      for (int k = 0; k < 3; ++k) {
        if (k > 0) {
          if (c.p >= c.end || *c.p != '/') break;
          ++c.p;
        }
        if (c.p < c.end && *c.p == '/') continue; // "v//vn": empty texcoord slot
        auto [q, ec] = std::from_chars(c.p, c.end, idx[k]);
        if (ec != std::errc() && k == 0) return fail(line, "bad face index");
        if (ec == std::errc()) c.p = q;
      }
      Corner corner{~0u, ~0u, ~0u};
      if (!resolve(idx[0], positions_.size(), corner.v))
        return fail(line, fmt::format("vertex index {} out of range ({} vertices defined)", idx[0], positions_.size()));
      if (idx[1] != 0 && !resolve(idx[1], uvs_.size(), corner.t))
        return fail(line, fmt::format("texcoord index {} out of range", idx[1]));
      if (idx[2] != 0 && !resolve(idx[2], normals_.size(), corner.n))
        return fail(line, fmt::format("normal index {} out of range", idx[2]));
      poly_.push_back(corner);
      if (c.p < c.end && *c.p != ' ' && *c.p != '\t' && *c.p != '\r' && *c.p != '\n' && *c.p != '#')
        return fail(line, "bad face syntax");
    }
    if (poly_.size() < 3) return fail(line, fmt::format("face has {} vertices (need at least 3)", poly_.size()));
    if (current_ < 0) current_ = groupFor("");
    Group& g = groups_[size_t(current_)];
    uint32_t first = vertexFor(g, poly_[0]), prev = vertexFor(g, poly_[1]);
    for (size_t k = 2; k < poly_.size(); ++k) {
      uint32_t cur = vertexFor(g, poly_[k]);
      g.mesh.indices.insert(g.mesh.indices.end(), {first, prev, cur});
      prev = cur;
    }
    return Ok{};
  }

  uint32_t vertexFor(Group& g, const Corner& c) {
    auto [it, inserted] = g.vertexOf.try_emplace(c, uint32_t(g.mesh.positions.size()));
    if (!inserted) return it->second;
    Mesh& m = g.mesh;
    m.positions.push_back(positions_[c.v]);
    // Attributes are all-or-nothing per mesh: a corner without uv/normal gets a zero that normals recompute fixes.
    if (c.t != ~0u || !m.uv0.empty()) {
      m.uv0.resize(m.positions.size() - 1);
      m.uv0.push_back(c.t != ~0u ? uvs_[c.t] : glm::vec2(0.0f));
    }
    if (c.n != ~0u || !m.normals.empty()) {
      m.normals.resize(m.positions.size() - 1, glm::vec3(0.0f, 0.0f, 1.0f));
      m.normals.push_back(c.n != ~0u ? normals_[c.n] : glm::vec3(0.0f, 0.0f, 1.0f));
    }
    if (!colors_.empty()) {
      m.colors.resize(m.positions.size() - 1, glm::vec4(1.0f));
      m.colors.push_back(c.v < colors_.size() ? colors_[c.v] : glm::vec4(1.0f));
    }
    return it->second;
  }

  int groupFor(const std::string& material) {
    auto it = materialIndex_.find(material);
    uint32_t mat;
    if (it != materialIndex_.end()) {
      mat = it->second;
    } else { // usemtl without a matching newmtl (or no usemtl): a default-looking material carrying the name
      mat = uint32_t(scene_.materials.size());
      Material m;
      m.name = material.empty() ? "default" : material;
      m.metallicFactor = 0.0f;
      scene_.materials.push_back(m);
      materialIndex_[material] = mat;
    }
    auto g = groupOfMaterial_.find(mat);
    if (g != groupOfMaterial_.end()) return g->second;
    groups_.emplace_back();
    groups_.back().mesh.material = mat;
    groups_.back().mesh.name = scene_.materials[mat].name;
    groupOfMaterial_[mat] = int(groups_.size() - 1);
    return int(groups_.size() - 1);
  }

  Status texture(const std::filesystem::path& dir, const Material& m, std::string_view kw, std::string_view spec,
                 bool srgb, int32_t& slot);
  Status mtllib(const std::string& names);
  Status loadMtl(const std::string& name);

  std::filesystem::path path_;
  std::string file_;
  ImportOptions options_;
  Scene scene_;
  std::vector<glm::vec3> positions_, normals_;
  std::vector<glm::vec2> uvs_;
  std::vector<glm::vec4> colors_;
  std::vector<Corner> poly_;
  std::vector<Group> groups_;
  int current_ = -1;
  std::unordered_map<std::string, uint32_t> materialIndex_;
  std::unordered_map<uint32_t, int> groupOfMaterial_;
  std::unordered_map<std::string, int> textureCache_;
};

// A map statement "map_Kd [-options ...] file": the file name is the last word.
Status ObjParser::texture(const std::filesystem::path& dir, const Material& m, std::string_view kw,
                          std::string_view spec, bool srgb, int32_t& slot) {
  slot = -1;
  if (!options_.loadTextures) return Ok{};
  size_t cut = spec.find_last_of(" \t");
  std::string fileName(cut == std::string_view::npos ? spec : spec.substr(cut + 1));
  std::replace(fileName.begin(), fileName.end(), '\\', '/');
  std::filesystem::path p = dir / fileName;
  std::string key = p.string() + (srgb ? "|s" : "|l");
  if (auto it = textureCache_.find(key); it != textureCache_.end()) {
    slot = it->second;
    return Ok{};
  }
  Texture t;
  std::string what = fmt::format("material {} {} {}", quoteInput(m.name), std::string(kw), quoteInput(fileName));
  if (Status s = detail::loadImageFile(p, file_, what, t); !s) return s;
  t.srgb = srgb;
  slot = int32_t(scene_.textures.size());
  scene_.textures.push_back(std::move(t));
  textureCache_[key] = slot;
  return Ok{};
}

// "mtllib a.mtl b.mtl" names several files; a single name may also contain spaces. The whole text is one file when
// such a file exists, otherwise each word is.
Status ObjParser::mtllib(const std::string& names) {
  if (names.find_first_of(" \t") == std::string::npos || inputFileProblem(path_.parent_path() / names).empty())
    return loadMtl(names);
  for (size_t at = 0; at < names.size();) {
    size_t end = std::min(names.find_first_of(" \t", at), names.size());
    if (end > at)
      if (Status s = loadMtl(names.substr(at, end - at)); !s) return s;
    at = end + 1;
  }
  return Ok{};
}

Status ObjParser::loadMtl(const std::string& name) {
  std::filesystem::path mtlPath = path_.parent_path() / name;
  if (std::string problem = inputFileProblem(mtlPath); !problem.empty())
    return makeError(file_, fmt::format("mtllib {}: {}", quoteInput(name), problem));
  auto data = detail::readFile(mtlPath);
  if (!data) return makeError(file_, fmt::format("mtllib {}: cannot read the file", quoteInput(name)));
  const std::vector<char>& buf = *data;
  Cursor c{buf.data(), buf.data() + buf.size()};
  const std::filesystem::path dir = mtlPath.parent_path();
  Material* m = nullptr;
  Status status = Ok{};
  while (c.p < c.end && status) {
    std::string_view kw = c.word();
    if (kw == "newmtl") {
      std::string n(c.restOfLine());
      uint32_t idx;
      if (auto it = materialIndex_.find(n); it != materialIndex_.end()) {
        idx = it->second;
      } else {
        idx = uint32_t(scene_.materials.size());
        scene_.materials.emplace_back();
        materialIndex_[n] = idx;
      }
      m = &scene_.materials[idx];
      m->name = n;
      m->metallicFactor = 0.0f; // OBJ materials are dielectric Phong; metal would render them dark
    } else if (m) {
      float a = 0, b = 0, d = 0;
      if (kw == "Kd" && c.number(a) && c.number(b) && c.number(d)) {
        m->baseColorFactor = glm::vec4(a, b, d, m->baseColorFactor.a);
      } else if (kw == "Ke" && c.number(a) && c.number(b) && c.number(d)) {
        m->emissiveFactor = glm::vec3(a, b, d);
      } else if ((kw == "d" || kw == "Tr") && c.number(a)) {
        m->baseColorFactor.a = kw == "d" ? a : 1.0f - a; // Tr is transparency, d is opacity
        m->alphaMode = m->baseColorFactor.a < 1.0f ? AlphaMode::Blend : AlphaMode::Opaque;
      } else if (kw == "Ns" && c.number(a)) {
        // Blinn-Phong exponent to GGX roughness: the usual alpha = sqrt(2 / (Ns + 2)) mapping.
        m->roughnessFactor = std::sqrt(2.0f / (std::max(a, 0.0f) + 2.0f));
      } else if (kw == "map_Kd") {
        status = texture(dir, *m, kw, c.restOfLine(), true, m->baseColorTexture);
      } else if (kw == "map_bump" || kw == "bump" || kw == "norm" || kw == "map_Bump") {
        status = texture(dir, *m, kw, c.restOfLine(), false, m->normalTexture);
      } else if (kw == "map_Ke") {
        status = texture(dir, *m, kw, c.restOfLine(), true, m->emissiveTexture);
      } else if (kw == "map_d" && m->alphaMode == AlphaMode::Opaque) {
        m->alphaMode = AlphaMode::Mask; // cut-out maps (foliage) rather than true translucency
      }
    }
    c.skipLine();
  }
  return status;
}

} // namespace

Result<Scene> importObj(const std::filesystem::path& path, const ImportOptions& options) {
  try {
    ObjParser parser(path, options);
    return parser.run();
  } catch (const std::exception& e) { // bad_alloc on absurd inputs: an Error, never a throw
    return makeError(detail::displayName(path), fmt::format("import failed: {}", escapeInput(e.what(), 240)));
  }
}

} // namespace mirage::io
