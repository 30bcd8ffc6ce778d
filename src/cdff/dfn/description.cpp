#include "cdff/dfn/description.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::dfn {

const char* toString(ParameterType type) {
  switch (type) {
    case ParameterType::kBool:
      return "bool";
    case ParameterType::kInt:
      return "int";
    case ParameterType::kDouble:
      return "double";
    case ParameterType::kString:
      return "string";
    case ParameterType::kDoubleList:
      return "double[]";
  }
  return "unknown";
}

double siPerUnit(std::string_view unit) {
  return unit == "deg" || unit == "deg/s" ? kRadiansPerDegree : 1.0;
}

std::string siUnit(std::string_view unit) {
  if (unit == "deg") return "rad";
  if (unit == "deg/s") return "rad/s";
  return std::string(unit);
}

std::string ParameterSpec::acceptedText() const {
  if (!allowed.empty()) return fmt::format("{{{}}}", fmt::join(allowed, ", "));
  std::string text;
  if (min || max) {
    text = fmt::format("[{}, {}]", min ? fmt::format("{}", *min) : "-inf",
                       max ? fmt::format("{}", *max) : "inf");
  }
  if (list_size) text += fmt::format("{}{} values", text.empty() ? "" : ", ", *list_size);
  if (text.empty()) text = type == ParameterType::kBool ? "true or false" : "any";
  return text;
}

std::optional<ParameterType> parameterTypeNamed(std::string_view name) {
  for (ParameterType t : {ParameterType::kBool, ParameterType::kInt, ParameterType::kDouble,
                          ParameterType::kString, ParameterType::kDoubleList})
    if (name == toString(t)) return t;
  return std::nullopt;
}

const ImplementationSpec* DfnDescription::findImplementation(const std::string& impl) const {
  for (const auto& i : implementations)
    if (i.name == impl) return &i;
  return nullptr;
}

}  // namespace cdff::dfn
