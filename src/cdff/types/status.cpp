#include "cdff/types/status.hpp"

namespace cdff {

const char* toString(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "ok";
    case StatusCode::kInvalidInput: return "invalid input";
    case StatusCode::kInvalidParameter: return "invalid parameter";
    case StatusCode::kNotConfigured: return "not configured";
    case StatusCode::kNotFound: return "not found";
    case StatusCode::kIoError: return "i/o error";
    case StatusCode::kCorruptData: return "corrupt data";
    case StatusCode::kNumericalFailure: return "numerical failure";
    case StatusCode::kTimeout: return "timeout";
    case StatusCode::kInternal: return "internal error";
  }
  return "unknown status";
}

std::string Status::toString() const {
  if (isOk()) return "ok";
  return fmt::format("{}: {}", cdff::toString(code_), message_);
}

Status Status::withContext(const std::string& context) const {
  if (isOk()) return *this;
  return {code_, context + ": " + message_};
}

}  // namespace cdff
