#pragma once
// Status: how every CDFF call reports success or a fault, without exceptions or exit().
//
// A non-OK status carries a code, a reason that says what went wrong, with which value and what
// was expected (e.g. "EdgeDetection/Canny input 'image': image is empty (0x0); expected a
// non-empty 8UC1 image"), and, when the fault is in a file, where: the location is data
// (SourceLocation), rendered first by message() ("graph.yaml:12:5: ..."), so that context added
// on the way up never pushes it out of the first place.

#include <source_location>
#include <string>
#include <utility>

#include <fmt/format.h>

namespace cdff {

enum class StatusCode {
  kOk = 0,
  kInvalidInput,      // a process() input is missing, empty, NaN, of the wrong size or format
  kInvalidParameter,  // configure() got an unknown key, a wrong type or an out-of-range value
  kNotConfigured,     // process() called before a successful configure()
  kNotFound,          // a named file, DFN, DFI, port or channel does not exist
  kIoError,           // reading or writing a file failed
  kCorruptData,       // a file or message is malformed or truncated
  kNumericalFailure,  // an algorithm diverged, a matrix was singular, a solver failed
  kTimeout,           // a budget (time, iterations) ran out
  kInternal,          // a bug: an unexpected exception or an invariant that did not hold
};

const char* toString(StatusCode code);

/// A place in a text file (1-based line and column; 0 when unknown), or in C++ code.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;

  static SourceLocation of(const std::source_location& where);
  bool empty() const { return file.empty() && line == 0; }
  /// "file:line:column: " (the prefix of an error message), "file: " without a line, "" when
  /// empty.
  std::string prefix() const;
  bool operator==(const SourceLocation&) const = default;
};

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string reason) : code_(code), reason_(std::move(reason)) {}
  Status(StatusCode code, std::string reason, SourceLocation where)
      : code_(code), reason_(std::move(reason)), location_(std::move(where)) {}

  static Status ok() { return {}; }

  bool isOk() const { return code_ == StatusCode::kOk; }
  explicit operator bool() const { return isOk(); }
  StatusCode code() const { return code_; }
  /// What went wrong, without the location.
  const std::string& reason() const { return reason_; }
  /// Where, when the fault is in a file (empty otherwise).
  const SourceLocation& location() const { return location_; }
  /// The location first (when there is one), then the reason: what a person reads.
  std::string message() const { return location_.prefix() + reason_; }
  /// "invalid input: <message>", or "ok".
  std::string toString() const;

  /// A copy whose reason is prefixed with `context: ` (e.g. the DFN instance name); the location
  /// stays first in message().
  Status withContext(const std::string& context) const;
  /// A copy located at `where` (an existing location is kept: it is the more precise one).
  Status at(const SourceLocation& where) const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string reason_;
  SourceLocation location_;
};

template <typename... Args>
Status invalidInput(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kInvalidInput, fmt::format(format, std::forward<Args>(args)...)};
}
template <typename... Args>
Status invalidParameter(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kInvalidParameter, fmt::format(format, std::forward<Args>(args)...)};
}
template <typename... Args>
Status numericalFailure(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kNumericalFailure, fmt::format(format, std::forward<Args>(args)...)};
}
template <typename... Args>
Status notFound(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kNotFound, fmt::format(format, std::forward<Args>(args)...)};
}
template <typename... Args>
Status ioError(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kIoError, fmt::format(format, std::forward<Args>(args)...)};
}
template <typename... Args>
Status corruptData(fmt::format_string<Args...> format, Args&&... args) {
  return {StatusCode::kCorruptData, fmt::format(format, std::forward<Args>(args)...)};
}

/// A value or the Status that explains why there is none.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}          // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design

  bool isOk() const { return status_.isOk(); }
  explicit operator bool() const { return isOk(); }
  const Status& status() const { return status_; }
  T& value() & { return value_; }
  const T& value() const& { return value_; }
  T&& value() && { return std::move(value_); }
  T* operator->() { return &value_; }
  const T* operator->() const { return &value_; }
  T& operator*() { return value_; }
  const T& operator*() const { return value_; }

 private:
  T value_{};
  Status status_;
};

}  // namespace cdff

#define CDFF_RETURN_IF_ERROR(expr)                 \
  do {                                             \
    ::cdff::Status cdff_status_ = (expr);          \
    if (!cdff_status_.isOk()) return cdff_status_; \
  } while (false)
