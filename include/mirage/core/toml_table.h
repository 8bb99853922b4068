#pragma once
// Reading one TOML table of a configuration file (material files, particle effect files): every
// key checked against the table's known keys, every value type- and range-checked where its line
// is known, each error one line "file:line: what: problem". Needs toml++ (Debian's
// libtomlplusplus, header-only): include it only from libraries that link tomlplusplus.
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "mirage/core/result.h"

namespace mirage {

// A number, integers included (toml++ converts them); booleans are not numbers.
inline std::optional<double> tomlNumber(const toml::node& n) {
  if (n.is_boolean()) return std::nullopt;
  return n.value<double>();
}

// A TOML syntax error as one line "file:line: description": toml++'s descriptions may quote the
// offending text, line breaks and control characters included.
inline Error tomlParseError(const std::string& file, const toml::parse_error& e) {
  std::string text(e.description());
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return Error{fmt::format("{}:{}: {}", file, e.source().begin.line, text)};
}

struct TomlTable {
  const toml::table& t;
  const std::string& file;
  std::string what; // what the table is: `material "steel"`, `system 1 shape`

  Error error(const toml::source_region& where, const std::string& problem) const {
    return Error{fmt::format("{}:{}: {}: {}", file, where.begin.line, what, problem)};
  }
  Error error(const std::string& problem) const { return error(t.source(), problem); }

  // Every key must be one of `known`: a misspelt key would otherwise be silently ignored.
  Status onlyKeys(std::initializer_list<std::string_view> known) const {
    for (const auto& [key, node] : t) {
      bool ok = false;
      for (std::string_view k : known) ok |= key.str() == k;
      if (!ok) return error(key.source(), fmt::format("unknown key \"{}\"", key.str()));
    }
    return Ok{};
  }

  const toml::node* get(std::string_view key) const { return t.get(key); }

  // `v` (the value of `key` at node `n`) finite and in lo..hi, into `out`.
  Status checked(std::string_view key, const toml::node& n, double v, float lo, float hi, float& out) const {
    if (!std::isfinite(v) || v < lo || v > hi)
      return error(n.source(), fmt::format("\"{}\" = {} is outside {}..{}", key, v, lo, hi));
    out = float(v);
    return Ok{};
  }

  // Optional keys: absent leaves `out` as it is.
  Status number(std::string_view key, float lo, float hi, float& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    std::optional<double> v = tomlNumber(*n);
    if (!v) return error(n->source(), fmt::format("\"{}\" must be a number", key));
    return checked(key, *n, *v, lo, hi, out);
  }

  Status count(std::string_view key, uint32_t lo, uint32_t hi, uint32_t& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    std::optional<int64_t> v = n->is_integer() ? n->value<int64_t>() : std::nullopt;
    if (!v) return error(n->source(), fmt::format("\"{}\" must be an integer", key));
    if (*v < int64_t(lo) || *v > int64_t(hi))
      return error(n->source(), fmt::format("\"{}\" = {} is outside {}..{}", key, *v, lo, hi));
    out = uint32_t(*v);
    return Ok{};
  }

  // An array node of minSize..maxSize numbers in lo..hi into out[0..]; its size in *size.
  Status array(std::string_view key, const toml::node& n, size_t minSize, size_t maxSize, float lo, float hi,
               float* out, size_t* size = nullptr) const {
    const toml::array* a = n.as_array();
    std::string shape = minSize == maxSize ? fmt::format("{}", minSize) : fmt::format("{} or {}", minSize, maxSize);
    if (!a || a->size() < minSize || a->size() > maxSize)
      return error(n.source(), fmt::format("\"{}\" must be an array of {} numbers", key, shape));
    for (size_t i = 0; i < a->size(); ++i) {
      std::optional<double> v = tomlNumber(*a->get(i));
      if (!v) return error(n.source(), fmt::format("\"{}\" must be an array of {} numbers", key, shape));
      if (!std::isfinite(*v) || *v < lo || *v > hi)
        return error(n.source(), fmt::format("\"{}\"[{}] = {} is outside {}..{}", key, i, *v, lo, hi));
      out[i] = float(*v);
    }
    if (size) *size = a->size();
    return Ok{};
  }
  Status array(std::string_view key, const toml::node& n, size_t size, float lo, float hi, float* out) const {
    return array(key, n, size, size, lo, hi, out);
  }

  Status numbers(std::string_view key, size_t minSize, size_t maxSize, float lo, float hi, float* out) const {
    const toml::node* n = get(key);
    return n ? array(key, *n, minSize, maxSize, lo, hi, out) : Status(Ok{});
  }
  Status numbers(std::string_view key, size_t size, float lo, float hi, float* out) const {
    return numbers(key, size, size, lo, hi, out);
  }

  Status string(std::string_view key, std::string& out, bool required = false) const {
    const toml::node* n = get(key);
    if (!n) return required ? error(fmt::format("missing key \"{}\"", key)) : Status(Ok{});
    if (!n->is_string()) return error(n->source(), fmt::format("\"{}\" must be a string", key));
    out = *n->value<std::string>();
    return Ok{};
  }

  Status boolean(std::string_view key, bool& out) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    if (!n->is_boolean()) return error(n->source(), fmt::format("\"{}\" must be true or false", key));
    out = *n->value<bool>();
    return Ok{};
  }

  // A string that must be one of `names`; its position in `index`.
  Status choice(std::string_view key, std::initializer_list<std::string_view> names, int& index) const {
    const toml::node* n = get(key);
    if (!n) return Ok{};
    std::string text;
    if (Status s = string(key, text); !s) return s;
    int i = 0;
    std::string expected;
    for (std::string_view name : names) {
      if (text == name) return index = i, Status(Ok{});
      expected += (i ? i + 1 == int(names.size()) ? " or " : ", " : "") + fmt::format("\"{}\"", name);
      ++i;
    }
    return error(n->source(), fmt::format("\"{}\" = \"{}\": expected {}", key, text, expected));
  }
};

} // namespace mirage
