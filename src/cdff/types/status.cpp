#include "cdff/types/status.hpp"

namespace cdff {

const char* toString(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return "ok";
    case StatusCode::kInvalidInput:
      return "invalid input";
    case StatusCode::kInvalidParameter:
      return "invalid parameter";
    case StatusCode::kNotConfigured:
      return "not configured";
    case StatusCode::kNotFound:
      return "not found";
    case StatusCode::kIoError:
      return "i/o error";
    case StatusCode::kCorruptData:
      return "corrupt data";
    case StatusCode::kNumericalFailure:
      return "numerical failure";
    case StatusCode::kTimeout:
      return "timeout";
    case StatusCode::kInternal:
      return "internal error";
  }
  return "unknown status";
}

SourceLocation SourceLocation::of(const std::source_location& where) {
  return {where.file_name(), static_cast<int>(where.line()), static_cast<int>(where.column())};
}

std::string SourceLocation::prefix() const {
  if (empty()) return "";
  const std::string name = file.empty() ? "<text>" : file;
  if (line <= 0) return name + ": ";
  if (column <= 0) return fmt::format("{}:{}: ", name, line);
  return fmt::format("{}:{}:{}: ", name, line, column);
}

std::string Status::toString() const {
  if (isOk()) return "ok";
  return fmt::format("{}: {}", cdff::toString(code_), message());
}

Status Status::withContext(const std::string& context) const {
  if (isOk()) return *this;
  return {code_, context + ": " + reason_, location_};
}

Status Status::at(const SourceLocation& where) const {
  if (isOk() || !location_.empty()) return *this;
  return {code_, reason_, where};
}

}  // namespace cdff
