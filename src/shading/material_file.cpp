// Material files: TOML through toml++ (Debian's libtomlplusplus), every key checked against the
// tables below, every number range-checked, every texture decoded. toml++ throws on syntax errors;
// the exception is caught here and never leaves the library.
#include "mirage/core/input_text.h"
#include "mirage/core/toml_table.h"
#include "mirage/shading/material_file.h"

#include <cmath>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "mirage/io/image_io.h"

namespace mirage::shading {

namespace {

// Early return of a failed Status or Result of a reading step.
#define MIRAGE_TRY(expr)                                                                                               \
  do {                                                                                                                 \
    if (auto status_ = (expr); !status_) return status_.error();                                                       \
  } while (0)

using Table = TomlTable;

// Bounds of the numbers a material file may hold: wide enough for any sensible scene, narrow
// enough that nothing overflows a float in the shaders.
constexpr float kMaxCoordinate = 1e7f; // light positions
constexpr float kMaxUv = 1e4f;         // UV scales and offsets
constexpr float kMaxEmissive = 1e4f;   // emissive and light colours x intensity stay finite in half floats' range
constexpr float kMaxStrength = 10.0f;  // normal strength

// The maps a file sets: key prefix, MaterialMap. Each has `<prefix>_texture`, `<prefix>_uv_scale`
// and `<prefix>_uv_offset`.
struct MapKey {
  const char* prefix;
  MaterialMap map;
};
constexpr MapKey kMapKeys[] = {{"albedo", kMapBaseColor},
                               {"normal", kMapNormal},
                               {"detail_albedo", kMapDetailAlbedo},
                               {"detail_normal", kMapDetailNormal},
                               {"detail_mask", kMapDetailMask}};

struct Parser {
  MaterialFile file;
  std::filesystem::path baseDir;

  // The texture `key` names, decoded once per resolved path; -1 when absent.
  Status texture(const Table& t, const std::string& key, int32_t& index) {
    std::string text;
    MIRAGE_TRY(t.string(key, text));
    if (!t.get(key)) return Ok{};
    const toml::source_region& where = t.get(key)->source();
    if (text.empty()) return t.error(where, fmt::format("\"{}\" is empty", key));
    std::filesystem::path p = std::filesystem::path(text);
    if (p.is_relative()) p = baseDir / p;
    p = p.lexically_normal();
    for (size_t i = 0; i < file.textures.size(); ++i)
      if (file.textures[i].path == p) return index = int32_t(i), Status(Ok{});
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p, ec))
      return t.error(where, fmt::format("\"{}\": {}: no such file", key, p.string()));
    auto image = io::readPng(p);
    if (!image) return t.error(where, fmt::format("\"{}\": {}", key, image.error().message));
    index = int32_t(file.textures.size());
    file.textures.push_back({p, std::move(*image)});
    return Ok{};
  }

  Status material(const toml::table& tt) {
    Table t{tt, file.name, "material"};
    std::string name;
    MIRAGE_TRY(t.string("name", name, /*required=*/true));
    if (name.empty()) return t.error(t.get("name")->source(), "\"name\" is empty");
    t.what = fmt::format("material \"{}\"", name);
    for (const MaterialDef& d : file.materials)
      if (d.material.name == name) return t.error(fmt::format("defined twice (first at line {})", d.line));
    MIRAGE_TRY(t.onlyKeys({"name",
                           "model",
                           "albedo",
                           "albedo_texture",
                           "albedo_uv_scale",
                           "albedo_uv_offset",
                           "normal_texture",
                           "normal_uv_scale",
                           "normal_uv_offset",
                           "normal_strength",
                           "detail_albedo_texture",
                           "detail_albedo_uv_scale",
                           "detail_albedo_uv_offset",
                           "detail_normal_texture",
                           "detail_normal_uv_scale",
                           "detail_normal_uv_offset",
                           "detail_mask_texture",
                           "detail_mask_uv_scale",
                           "detail_mask_uv_offset",
                           "uv_scale",
                           "uv_offset",
                           "alpha_mode",
                           "alpha_cutoff",
                           "double_sided",
                           "metallic",
                           "roughness",
                           "glossiness",
                           "specular",
                           "emissive"}));
    MaterialDef d;
    d.line = uint32_t(tt.source().begin.line);
    Material& m = d.material;
    m.name = name;
    m.origin = fmt::format("{}:{}", file.name, d.line);
    int model = 0;
    MIRAGE_TRY(t.choice("model", {"metallic-roughness", "blinn-phong"}, model));
    m.model = model == 0 ? ShadingModel::MetallicRoughness : ShadingModel::BlinnPhong;
    // Keys of the other model are errors: they would have no effect.
    static constexpr const char* kOnlyFor[2][2] = {{"glossiness", "specular"}, {"metallic", "roughness"}};
    for (const char* key : kOnlyFor[model])
      if (const toml::node* n = t.get(key))
        return t.error(n->source(), fmt::format("\"{}\" does not apply to model \"{}\"", key,
                                                model == 0 ? "metallic-roughness" : "blinn-phong"));
    float albedo[4] = {1, 1, 1, 1};
    MIRAGE_TRY(t.numbers("albedo", 3, 4, 0.0f, 1.0f, albedo)); // 3 numbers: alpha stays 1
    m.baseColorFactor = {albedo[0], albedo[1], albedo[2], albedo[3]};
    MIRAGE_TRY(t.numbers("emissive", 3, 3, 0.0f, kMaxEmissive, &m.emissiveFactor.x));
    m.metallicFactor = 0.0f; // a file's material is a dielectric unless it says otherwise
    m.roughnessFactor = 0.5f;
    MIRAGE_TRY(t.number("metallic", 0.0f, 1.0f, m.metallicFactor));
    MIRAGE_TRY(t.number("roughness", 0.0f, 1.0f, m.roughnessFactor));
    MIRAGE_TRY(t.number("glossiness", 0.0f, 1.0f, m.glossiness));
    MIRAGE_TRY(t.numbers("specular", 3, 3, 0.0f, 1.0f, &m.specularColor.x));
    MIRAGE_TRY(t.number("normal_strength", 0.0f, kMaxStrength, m.normalScale));
    MIRAGE_TRY(t.boolean("double_sided", m.doubleSided));
    int alpha = 0;
    MIRAGE_TRY(t.choice("alpha_mode", {"OPAQUE", "MASK", "BLEND"}, alpha));
    m.alphaMode = AlphaMode(alpha);
    if (const toml::node* n = t.get("alpha_cutoff"); n && m.alphaMode != AlphaMode::Mask)
      return t.error(n->source(), "\"alpha_cutoff\" needs alpha_mode = \"MASK\"");
    MIRAGE_TRY(t.number("alpha_cutoff", 0.0f, 1.0f, m.alphaCutoff));
    // UV transforms: uv_scale/uv_offset for every map, <map>_uv_scale/_offset for one.
    UvTransform all;
    MIRAGE_TRY(t.numbers("uv_scale", 2, 2, -kMaxUv, kMaxUv, &all.scale.x));
    MIRAGE_TRY(t.numbers("uv_offset", 2, 2, -kMaxUv, kMaxUv, &all.offset.x));
    for (UvTransform& uv : m.uv) uv = all;
    for (const MapKey& k : kMapKeys) {
      std::string prefix = k.prefix;
      MIRAGE_TRY(texture(t, prefix + "_texture", d.textures[k.map]));
      MIRAGE_TRY(t.numbers(prefix + "_uv_scale", 2, 2, -kMaxUv, kMaxUv, &m.uv[k.map].scale.x));
      MIRAGE_TRY(t.numbers(prefix + "_uv_offset", 2, 2, -kMaxUv, kMaxUv, &m.uv[k.map].offset.x));
    }
    if (d.textures[kMapDetailMask] >= 0 && d.textures[kMapDetailAlbedo] < 0 && d.textures[kMapDetailNormal] < 0)
      return t.error(t.get("detail_mask_texture")->source(),
                     "\"detail_mask_texture\" needs detail_albedo_texture or detail_normal_texture");
    file.materials.push_back(std::move(d));
    return Ok{};
  }

  Status assignment(const toml::table& tt) {
    Table t{tt, file.name, "assign"};
    MIRAGE_TRY(t.onlyKeys({"mesh", "material", "use"}));
    Assignment a;
    a.line = uint32_t(tt.source().begin.line);
    bool mesh = t.get("mesh") != nullptr, material = t.get("material") != nullptr;
    if (mesh == material) return t.error("needs exactly one of \"mesh\" and \"material\" (a name or glob)");
    a.target = mesh ? Assignment::Target::Mesh : Assignment::Target::Material;
    MIRAGE_TRY(t.string(mesh ? "mesh" : "material", a.pattern));
    if (a.pattern.empty()) return t.error(t.get(mesh ? "mesh" : "material")->source(), "the pattern is empty");
    std::string use;
    MIRAGE_TRY(t.string("use", use, /*required=*/true));
    bool found = false;
    for (size_t i = 0; i < file.materials.size() && !found; ++i)
      if (file.materials[i].material.name == use) a.material = uint32_t(i), found = true;
    if (!found)
      return t.error(t.get("use")->source(), fmt::format("\"use\" = \"{}\": no [[material]] of that name", use));
    file.assignments.push_back(std::move(a));
    return Ok{};
  }

  Status light(const toml::table& tt) {
    Table t{tt, file.name, fmt::format("light {}", file.lights.size() + 1)};
    MIRAGE_TRY(t.onlyKeys({"position", "color", "intensity", "radius"}));
    PointLight l;
    if (!t.get("position")) return t.error("missing key \"position\"");
    MIRAGE_TRY(t.numbers("position", 3, 3, -kMaxCoordinate, kMaxCoordinate, &l.position.x));
    MIRAGE_TRY(t.numbers("color", 3, 3, 0.0f, 1.0f, &l.color.x));
    MIRAGE_TRY(t.number("intensity", 0.0f, kMaxEmissive, l.intensity));
    MIRAGE_TRY(t.number("radius", 1e-3f, kMaxCoordinate, l.radius));
    file.lights.push_back(l);
    return Ok{};
  }

  // [[material]] first: [[assign]] refers to materials by name wherever they stand in the file.
  Status document(const toml::table& root) {
    Table top{root, file.name, "top level"};
    MIRAGE_TRY(top.onlyKeys({"material", "assign", "light"}));
    for (const char* key : {"material", "assign", "light"}) {
      const toml::node* n = root.get(key);
      if (!n) continue;
      const toml::array* list = n->as_array();
      if (!list || !list->is_array_of_tables())
        return top.error(n->source(), fmt::format("\"{}\" must be an array of tables ([[{}]])", key, key));
      for (const toml::node& entry : *list) {
        const toml::table& table = *entry.as_table();
        Status s = key[0] == 'm' ? material(table) : key[0] == 'a' ? Status(Ok{}) : light(table);
        if (!s) return s;
      }
    }
    if (const toml::array* list = root.get_as<toml::array>("assign"))
      for (const toml::node& entry : *list) MIRAGE_TRY(assignment(*entry.as_table()));
    return Ok{};
  }
};

} // namespace

Result<MaterialFile> parseMaterialFile(std::string_view text, const std::string& name,
                                       const std::filesystem::path& baseDir) {
  Parser p;
  p.file.name = name;
  p.baseDir = baseDir;
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    return tomlParseError(name, e);
  }
  MIRAGE_TRY(p.document(root));
  return std::move(p.file);
}

Result<MaterialFile> loadMaterialFile(const std::filesystem::path& path) {
  std::string name = path.string();
  Result<std::string> text = readInputText(path, kMaxMaterialFileBytes, "a material file");
  if (!text) return text.error();
  return parseMaterialFile(*text, name, path.parent_path());
}

} // namespace mirage::shading
