#pragma once
// Errors at library boundaries: a Result<T> holds a value or a one-line Error naming the file and
// the problem. Libraries never throw across their API; the CLI prints Error::message and exits 2.
#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace mirage {

struct Error {
  std::string message; // one line: "<file>: <problem>"
};

inline Error makeError(const std::string& file, const std::string& problem) { return Error{file + ": " + problem}; }

template <class T> class [[nodiscard]] Result {
public:
  Result(T value) : state_(std::move(value)) {}
  Result(Error error) : state_(std::move(error)) {}

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() & {
    assert(ok());
    return std::get<0>(state_);
  }
  const T& value() const& {
    assert(ok());
    return std::get<0>(state_);
  }
  T&& value() && {
    assert(ok());
    return std::get<0>(std::move(state_));
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  const Error& error() const {
    assert(!ok());
    return std::get<1>(state_);
  }

private:
  std::variant<T, Error> state_;
};

// Result<void>: success or an error.
struct Ok {};
using Status = Result<Ok>;

} // namespace mirage
