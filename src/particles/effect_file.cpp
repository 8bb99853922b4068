// Effect files: TOML through toml++ (Debian's libtomlplusplus). Every key is checked against the
// tables below and every number range-checked here, where the key's line is known; cross-field
// rules live in validateSystem (effect.cpp). toml++ throws on syntax errors; the exception is
// caught here and never leaves the library.
#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "mirage/core/input_text.h"
#include "mirage/core/toml_table.h"
#include "mirage/particles/effect.h"

namespace mirage::particles {

namespace {

#define MIRAGE_TRY(expr)                                                                                               \
  do {                                                                                                                 \
    if (auto status_ = (expr); !status_) return status_.error();                                                       \
  } while (0)
// The same around a module reader whose body uses MIRAGE_TRY itself.
#define MIRAGE_TRY_MODULE(expr)                                                                                        \
  do {                                                                                                                 \
    if (auto module_ = (expr); !module_) return module_.error();                                                       \
  } while (0)

// One table of an effect file: the shared checks (core/toml_table.h) and the value shapes of
// effects (random ranges, curves, gradients, modules).
struct Table : TomlTable {
  // A number (a constant) or [min, max] (a random value per particle).
  Status range(std::string_view key, float lo, float hi, Range& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    if (std::optional<double> v = tomlNumber(*n); v && !n->is_array()) {
      MIRAGE_TRY(checked(key, *n, *v, lo, hi, out.min));
      out.max = out.min;
      return Ok{};
    }
    const toml::array* a = n->as_array();
    if (!a || a->size() != 2) return error(n->source(), fmt::format("\"{}\" must be a number or [min, max]", key));
    float v[2];
    MIRAGE_TRY(array(key, *n, 2, lo, hi, v));
    out = {v[0], v[1]};
    return Ok{};
  }

  // [x, y, z] (a constant) or [[min x, y, z], [max x, y, z]].
  Status range3(std::string_view key, float lo, float hi, Range3& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    const toml::array* a = n->as_array();
    if (a && a->size() == 2 && a->get(0)->is_array() && a->get(1)->is_array()) {
      MIRAGE_TRY(array(key, *a->get(0), 3, lo, hi, &out.min.x));
      return array(key, *a->get(1), 3, lo, hi, &out.max.x);
    }
    if (!a || a->size() != 3) return error(n->source(), fmt::format("\"{}\" must be [x, y, z] or [[min], [max]]", key));
    MIRAGE_TRY(array(key, *n, 3, lo, hi, &out.min.x));
    out.max = out.min;
    return Ok{};
  }

  // [r, g, b, a] (a constant) or [[r, g, b, a], [r, g, b, a]] (random between the two).
  Status colorRange(std::string_view key, ColorRange& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    const toml::array* a = n->as_array();
    if (a && a->size() == 2 && a->get(0)->is_array() && a->get(1)->is_array()) {
      MIRAGE_TRY(array(key, *a->get(0), 4, 0.0f, 1.0f, &out.min.x));
      return array(key, *a->get(1), 4, 0.0f, 1.0f, &out.max.x);
    }
    MIRAGE_TRY(array(key, *n, 4, 0.0f, 1.0f, &out.min.x));
    out.max = out.min;
    return Ok{};
  }

  // A table under `key` (a module), or nullptr when absent.
  Result<const toml::table*> module(std::string_view key) const {
    const toml::node* n = get(key);
    if (!n) return static_cast<const toml::table*>(nullptr);
    if (!n->is_table()) return error(n->source(), fmt::format("\"{}\" must be a table ([system.{}])", key, key));
    return n->as_table();
  }

  // Keys [[t, value...]] of a curve or gradient: `width` numbers per key, t in [0, 1].
  Status keys(std::string_view key, size_t width, float lo, float hi, std::vector<std::vector<float>>& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    const toml::array* a = n->as_array();
    if (!a || a->empty() || a->size() > kMaxCurveKeys)
      return error(n->source(), fmt::format("\"{}\" must be an array of 1..{} keys", key, kMaxCurveKeys));
    for (const toml::node& k : *a) {
      std::vector<float> v(width);
      MIRAGE_TRY(array(key, k, width, lo, hi, v.data()));
      if (v[0] < 0.0f || v[0] > 1.0f)
        return error(k.source(), fmt::format("\"{}\": key time {} is outside 0..1", key, v[0]));
      out.push_back(std::move(v));
    }
    return Ok{};
  }
};

struct Parser {
  EffectFile file;

  Status shape(const Table& s, SystemDef& d) {
    auto m = s.module("shape");
    if (!m) return m.error();
    if (!*m) return Ok{};
    Table t{{**m, file.name, s.what + " shape"}};
    MIRAGE_TRY(t.onlyKeys({"type", "radius", "radius_thickness", "arc", "angle", "size", "emit_from", "position",
                           "rotation", "scale", "randomize_direction", "randomize_position"}));
    ShapeModule& sh = d.shape;
    int type = int(sh.type);
    MIRAGE_TRY(t.choice("type", {"sphere", "hemisphere", "cone", "circle", "box", "edge"}, type));
    sh.type = ShapeType(type);
    MIRAGE_TRY(t.number("radius", 0.0f, kMaxCoordinate, sh.radius));
    MIRAGE_TRY(t.number("radius_thickness", 0.0f, 1.0f, sh.radiusThickness));
    MIRAGE_TRY(t.number("arc", 0.0f, 360.0f, sh.arcDegrees));
    MIRAGE_TRY(t.number("angle", 0.0f, 90.0f, sh.angleDegrees));
    MIRAGE_TRY(t.numbers("size", 3, 0.0f, kMaxCoordinate, &sh.boxSize.x));
    if (const toml::node* n = t.get("emit_from")) {
      if (sh.type == ShapeType::Box) {
        int mode = 0;
        MIRAGE_TRY(t.choice("emit_from", {"volume", "shell", "edge"}, mode));
        sh.boxEmit = BoxEmit(mode);
      } else {
        // Radial shapes: "volume" and "shell" set the radius thickness (1 and 0).
        int mode = 0;
        MIRAGE_TRY(t.choice("emit_from", {"volume", "shell"}, mode));
        if (t.get("radius_thickness"))
          return t.error(n->source(), "\"emit_from\" and \"radius_thickness\" exclude each other");
        sh.radiusThickness = mode == 0 ? 1.0f : 0.0f;
      }
    }
    MIRAGE_TRY(t.numbers("position", 3, -kMaxCoordinate, kMaxCoordinate, &sh.position.x));
    MIRAGE_TRY(t.numbers("rotation", 3, -3600.0f, 3600.0f, &sh.rotationDegrees.x));
    MIRAGE_TRY(t.numbers("scale", 3, -kMaxCoordinate, kMaxCoordinate, &sh.scale.x));
    MIRAGE_TRY(t.number("randomize_direction", 0.0f, 1.0f, sh.randomizeDirection));
    MIRAGE_TRY(t.number("randomize_position", 0.0f, kMaxCoordinate, sh.randomizePosition));
    return Ok{};
  }

  Status gradient(const Table& t, std::string_view key, Gradient& out) {
    std::vector<std::vector<float>> keys;
    MIRAGE_TRY(t.keys(key, 5, 0.0f, 1.0f, keys));
    for (const auto& k : keys) {
      out.times.push_back(k[0]);
      out.colors.push_back({k[1], k[2], k[3], k[4]});
    }
    return Ok{};
  }

  Status modules(const Table& s, SystemDef& d) {
    MIRAGE_TRY(shape(s, d));
    constexpr float kMaxVelocity = 1e5f;
    // Each module: its key, the keys it takes, and how they are read.
    auto read = [&](std::string_view key, std::initializer_list<std::string_view> known, auto&& body) -> Status {
      auto m = s.module(key);
      if (!m) return m.error();
      if (!*m) return Ok{};
      Table t{{**m, file.name, s.what + " " + std::string(key)}};
      MIRAGE_TRY(t.onlyKeys(known));
      return body(t);
    };
    MIRAGE_TRY_MODULE(read("velocity_over_lifetime", {"velocity"}, [&](const Table& t) {
      return t.range3("velocity", -kMaxVelocity, kMaxVelocity, d.velocityOverLifetime);
    }));
    MIRAGE_TRY_MODULE(read("force_over_lifetime", {"force"}, [&](const Table& t) {
      return t.range3("force", -kMaxVelocity, kMaxVelocity, d.forceOverLifetime);
    }));
    MIRAGE_TRY_MODULE(read("rotation_over_lifetime", {"angular_velocity"}, [&](const Table& t) {
      return t.range("angular_velocity", -1e5f, 1e5f, d.angularVelocityDegrees);
    }));
    MIRAGE_TRY_MODULE(read("size_over_lifetime", {"curve"}, [&](const Table& t) -> Status {
      std::vector<std::vector<float>> keys;
      MIRAGE_TRY(t.keys("curve", 2, 0.0f, kMaxCoordinate, keys));
      for (const auto& k : keys) d.sizeOverLifetime.keys.push_back({k[0], k[1]});
      return Ok{};
    }));
    MIRAGE_TRY_MODULE(read("color_over_lifetime", {"gradient"},
                           [&](const Table& t) { return gradient(t, "gradient", d.colorOverLifetime); }));
    MIRAGE_TRY_MODULE(read("color_over_speed", {"gradient", "range"}, [&](const Table& t) -> Status {
      MIRAGE_TRY(gradient(t, "gradient", d.colorOverSpeed));
      float r[2] = {d.colorOverSpeedRange.min, d.colorOverSpeedRange.max};
      MIRAGE_TRY(t.numbers("range", 2, 0.0f, kMaxVelocity, r));
      d.colorOverSpeedRange = {r[0], r[1]};
      return Ok{};
    }));
    return read("texture_sheet", {"mode", "row", "random_row", "cycles", "start_frame"}, [&](const Table& t) -> Status {
      int mode = 0;
      MIRAGE_TRY(t.choice("mode", {"whole_sheet", "single_row"}, mode));
      d.sheet.singleRow = mode == 1;
      MIRAGE_TRY(t.count("row", 0, kMaxSheetTiles - 1, d.sheet.row));
      MIRAGE_TRY(t.boolean("random_row", d.sheet.randomRow));
      MIRAGE_TRY(t.number("cycles", 0.0f, 1e4f, d.sheet.cycles));
      return t.range("start_frame", 0.0f, float(kMaxSheetTiles * kMaxSheetTiles), d.sheet.startFrame);
    });
  }

  Status system(const toml::table& tt) {
    SystemDef d;
    d.line = uint32_t(tt.source().begin.line);
    d.name = fmt::format("{}", file.systems.size() + 1);
    Table s{{tt, file.name, fmt::format("system {}", d.name)}};
    if (const toml::node* n = s.get("name")) {
      MIRAGE_TRY(s.string("name", d.name));
      if (d.name.empty()) return s.error(n->source(), "\"name\" is empty");
      s.what = fmt::format("system \"{}\"", d.name);
      for (const SystemDef& o : file.systems)
        if (o.name == d.name) return s.error(fmt::format("defined twice (first at line {})", o.line));
    }
    MIRAGE_TRY(s.onlyKeys({"name",
                           "position",
                           "rotation",
                           "duration",
                           "looping",
                           "prewarm",
                           "start_delay",
                           "start_lifetime",
                           "start_speed",
                           "start_size",
                           "start_rotation",
                           "start_color",
                           "gravity_modifier",
                           "max_particles",
                           "rate_over_time",
                           "seed",
                           "texture",
                           "tiles",
                           "alpha_from_greyscale",
                           "shape",
                           "velocity_over_lifetime",
                           "force_over_lifetime",
                           "size_over_lifetime",
                           "rotation_over_lifetime",
                           "color_over_lifetime",
                           "color_over_speed",
                           "texture_sheet"}));
    MIRAGE_TRY(s.numbers("position", 3, -kMaxCoordinate, kMaxCoordinate, &d.position.x));
    MIRAGE_TRY(s.numbers("rotation", 3, -3600.0f, 3600.0f, &d.rotationDegrees.x));
    MIRAGE_TRY(s.number("duration", 1e-3f, kMaxSeconds, d.duration));
    MIRAGE_TRY(s.boolean("looping", d.looping));
    MIRAGE_TRY(s.boolean("prewarm", d.prewarm));
    MIRAGE_TRY(s.number("start_delay", 0.0f, kMaxSeconds, d.startDelay));
    MIRAGE_TRY(s.range("start_lifetime", 1e-3f, kMaxSeconds, d.startLifetime));
    MIRAGE_TRY(s.range("start_speed", -1e5f, 1e5f, d.startSpeed));
    MIRAGE_TRY(s.range("start_size", 0.0f, kMaxCoordinate, d.startSize));
    MIRAGE_TRY(s.range("start_rotation", -3600.0f, 3600.0f, d.startRotationDegrees));
    MIRAGE_TRY(s.colorRange("start_color", d.startColor));
    MIRAGE_TRY(s.number("gravity_modifier", -1e3f, 1e3f, d.gravityModifier));
    MIRAGE_TRY(s.count("max_particles", 1, kMaxParticlesPerSystem, d.maxParticles));
    MIRAGE_TRY(s.number("rate_over_time", 0.0f, 1e9f, d.rateOverTime));
    MIRAGE_TRY(s.count("seed", 0, UINT32_MAX, d.seed));
    MIRAGE_TRY(s.string("texture", d.sheet.texture));
    if (const toml::node* n = s.get("tiles")) {
      float tiles[2];
      MIRAGE_TRY(s.array("tiles", *n, 2, 1.0f, float(kMaxSheetTiles), tiles));
      if (tiles[0] != std::floor(tiles[0]) || tiles[1] != std::floor(tiles[1]))
        return s.error(n->source(), "\"tiles\" must be two whole numbers");
      d.sheet.tilesX = uint32_t(tiles[0]);
      d.sheet.tilesY = uint32_t(tiles[1]);
    }
    MIRAGE_TRY(s.boolean("alpha_from_greyscale", d.sheet.alphaFromGreyscale));
    MIRAGE_TRY(modules(s, d));
    if (Status v = validateSystem(d); !v) return s.error(v.error().message);
    file.systems.push_back(std::move(d));
    return Ok{};
  }

  Status document(const toml::table& root) {
    Table top{{root, file.name, "top level"}};
    MIRAGE_TRY(top.onlyKeys({"system"}));
    const toml::node* n = root.get("system");
    if (!n) return top.error("no [[system]]");
    const toml::array* list = n->as_array();
    if (!list || !list->is_array_of_tables()) return top.error(n->source(), "\"system\" must be [[system]] tables");
    if (list->size() > kMaxSystems)
      return top.error(n->source(), fmt::format("{} systems, more than {}", list->size(), kMaxSystems));
    for (const toml::node& entry : *list) MIRAGE_TRY(system(*entry.as_table()));
    return Ok{};
  }
};

} // namespace

Result<EffectFile> parseEffectFile(std::string_view text, const std::string& name) {
  Parser p;
  p.file.name = name;
  toml::table root;
  try {
    root = toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    return tomlParseError(name, e);
  }
  MIRAGE_TRY(p.document(root));
  return std::move(p.file);
}

Result<EffectFile> loadEffectFile(const std::filesystem::path& path) {
  std::string name = path.string();
  Result<std::string> text = readInputText(path, kMaxEffectFileBytes, "an effect file");
  if (!text) return text.error();
  return parseEffectFile(*text, name);
}

} // namespace mirage::particles
