#pragma once
/// Expected failures (bad uploads, nothing graspable) travel as values; broken preconditions throw.

#include <stdexcept>
#include <string>
#include <utility>
#include <variant>

namespace softgrasp::core {

/// What kind of expected failure happened, in the caller's terms; each front end (the REST API's
/// rest::HttpStatusFor, the command-line tools' exit codes) maps the kinds to its own.
enum class ErrorCode {
  kInvalidArgument,    ///< a parameter or field is malformed or out of range
  kUnsupportedFormat,  ///< the bytes are not a format we decode
  kTooLarge,           ///< too many pixels, points, triangles or bytes for the configured limits
  kUnprocessable,      ///< well-formed but cannot be used, e.g. an all-missing depth image
  kNotFound,           ///< what was named does not exist
  kInternal,           ///< a bug on our side
  kUnauthenticated,    ///< no or malformed credentials
  kPermissionDenied,   ///< credentials given but not accepted
  kConflict,           ///< clashes with existing state, e.g. an id reused for another body
  kUnavailable,        ///< a needed party is not there now (no robot alive); retry later
};

struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;  ///< human-readable, says what is wrong and what is expected
  std::string field;    ///< the request field at fault, empty when none applies
};

/// A value or an Error. Minimal on purpose: `ok()`, `value()`, `error()`.
template <class T>
class Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return std::holds_alternative<T>(v_); }
  explicit operator bool() const { return ok(); }

  /// @throws std::logic_error if this holds an Error.
  T& value() & { return Checked(); }
  const T& value() const& { return const_cast<Result*>(this)->Checked(); }
  T&& value() && { return std::move(Checked()); }

  /// @pre !ok()
  const Error& error() const { return std::get<Error>(v_); }

 private:
  T& Checked() {
    if (!ok()) throw std::logic_error("Result::value() on error: " + std::get<Error>(v_).message);
    return std::get<T>(v_);
  }
  std::variant<T, Error> v_;
};

inline Error MakeError(ErrorCode code, std::string message, std::string field = {}) {
  return Error{code, std::move(message), std::move(field)};
}

}  // namespace softgrasp::core
