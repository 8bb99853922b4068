#pragma once
// Parsing an enum from its name: the value whose toString() (found by argument-dependent lookup in
// the enum's namespace) is `text`, for CLI options and settings of every module.
#include <initializer_list>
#include <string>
#include <string_view>

#include "mirage/core/result.h"

namespace mirage {

// The enum value whose toString() is `text`; otherwise an error naming `label`, the text and every
// choice, e.g. "--raster 'x': expected auto, mesh, indirect, compute or hybrid".
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
