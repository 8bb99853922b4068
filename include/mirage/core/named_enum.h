#pragma once
// Enum names: one table per enum (value, name) serves toString, parsing and the CLI binding, for
// CLI options and settings of every module.
#include <cstddef>
#include <initializer_list>
#include <string>
#include <string_view>

#include "mirage/core/result.h"

namespace mirage {

template <typename E> struct EnumName {
  E value;
  const char* name;
};

// The name of `value` in `table`; "?" when it has none.
template <typename E, size_t N> constexpr const char* nameOf(const EnumName<E> (&table)[N], E value) {
  for (const EnumName<E>& e : table)
    if (e.value == value) return e.name;
  return "?";
}

// The value named `text` in `table`; otherwise an error naming `label`, the text and every choice,
// e.g. "--raster 'x': expected auto, mesh, indirect, compute or hybrid".
template <typename E, size_t N>
Result<E> parseNamed(std::string_view text, std::string_view label, const EnumName<E> (&table)[N]) {
  std::string choices;
  for (size_t i = 0; i < N; ++i) {
    if (text == table[i].name) return table[i].value;
    choices += i == 0 ? "" : i + 1 == N ? " or " : ", ";
    choices += table[i].name;
  }
  return Error{std::string(label) + " '" + std::string(text) + "': expected " + choices};
}

// The enum value whose toString() (found by argument-dependent lookup in the enum's namespace) is
// `text`; for enums without a table.
template <typename E>
Result<E> parseNamed(std::string_view text, std::string_view label, std::initializer_list<E> values) {
  std::string choices;
  size_t i = 0;
  for (E v : values) {
    if (text == toString(v)) return v;
    choices += i == 0 ? "" : i + 1 == values.size() ? " or " : ", ";
    choices += toString(v);
    ++i;
  }
  return Error{std::string(label) + " '" + std::string(text) + "': expected " + choices};
}

} // namespace mirage
