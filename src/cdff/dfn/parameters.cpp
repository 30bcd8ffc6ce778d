#include "cdff/dfn/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::dfn {

namespace {

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1] ? 1 : 0)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string suggestion(const std::string& key, const std::vector<ParameterSpec>& specs) {
  const ParameterSpec* best = nullptr;
  std::size_t best_distance = 3;  // only suggest near misses
  for (const auto& s : specs) {
    const std::size_t d = editDistance(key, s.name);
    if (d < best_distance) {
      best = &s;
      best_distance = d;
    }
  }
  return best ? fmt::format(" (did you mean '{}'?)", best->name) : "";
}

std::string unitSuffix(const ParameterSpec& spec) {
  return spec.unit.empty() ? "" : fmt::format(" {}", spec.unit);
}

}  // namespace

Status checkNumber(const ParameterSpec& spec, double value, const std::string& value_text) {
  if (!std::isfinite(value))
    return invalidParameter("parameter '{}' = {} is not a finite number; expected {}{}", spec.name,
                            value_text, spec.acceptedText(), unitSuffix(spec));
  if ((spec.min && value < *spec.min) || (spec.max && value > *spec.max))
    return invalidParameter("parameter '{}' = {} is out of range; expected {}{}", spec.name,
                            value_text, spec.acceptedText(), unitSuffix(spec));
  return Status::ok();
}

Status checkString(const ParameterSpec& spec, const std::string& value) {
  if (!spec.allowed.empty() &&
      std::find(spec.allowed.begin(), spec.allowed.end(), value) == spec.allowed.end())
    return invalidParameter("parameter '{}' = '{}' is not an accepted value; expected one of {}",
                            spec.name, value, spec.acceptedText());
  return Status::ok();
}

Status checkList(const ParameterSpec& spec, const std::vector<double>& value) {
  if (spec.list_size && value.size() != *spec.list_size)
    return invalidParameter("parameter '{}' has {} values; expected {}", spec.name, value.size(),
                            *spec.list_size);
  for (std::size_t i = 0; i < value.size(); ++i) {
    Status s = checkNumber(spec, value[i], fmt::format("{}", value[i]));
    if (!s)
      return invalidParameter("parameter '{}' element {} = {} is out of range; expected {}{}",
                              spec.name, i, value[i], spec.acceptedText(), unitSuffix(spec));
  }
  return Status::ok();
}

ParameterReader::ParameterReader(const YAML::Node& node, std::string source, std::string owner)
    : node_(node), source_(std::move(source)), owner_(std::move(owner)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) {
    status_ = invalidParameter("{}{} parameters must be a YAML map of name: value; got a {}",
                               where(node_), owner_, node_.IsSequence() ? "sequence" : "scalar");
  }
}

std::string ParameterReader::where(const YAML::Node& node) const {
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return fmt::format("{}: ", source_);
  return fmt::format("{}:{}:{}: ", source_, mark.line + 1, mark.column + 1);
}

template <typename T>
void ParameterReader::readScalar(const ParameterSpec& spec, T& value, const char* type_name) {
  if (!status_ || !node_ || !node_.IsMap()) return;
  const YAML::Node item = node_[spec.name];
  if (!item) return;  // keep the default
  const std::string text = item.IsScalar() ? item.Scalar() : std::string("<") +
                                                                 (item.IsMap() ? "map" : "sequence") + ">";
  T parsed{};
  if (!item.IsScalar() || !YAML::convert<T>::decode(item, parsed)) {
    status_ = invalidParameter("{}{} parameter '{}' = {} is not {}; expected {}{}", where(item),
                               owner_, spec.name, text, type_name, spec.acceptedText(),
                               unitSuffix(spec));
    return;
  }
  Status check;
  if constexpr (std::is_same_v<T, std::string>) {
    check = checkString(spec, parsed);
  } else if constexpr (!std::is_same_v<T, bool>) {
    check = checkNumber(spec, static_cast<double>(parsed), text);
  }
  if (!check) {
    status_ = check.withContext(fmt::format("{}{}", where(item), owner_));
    return;
  }
  value = std::move(parsed);
}

void ParameterReader::read(const ParameterSpec& spec, bool& value) {
  readScalar(spec, value, "a bool");
}
void ParameterReader::read(const ParameterSpec& spec, int& value) {
  readScalar(spec, value, "an int");
}
void ParameterReader::read(const ParameterSpec& spec, double& value) {
  readScalar(spec, value, "a number");
}
void ParameterReader::read(const ParameterSpec& spec, std::string& value) {
  readScalar(spec, value, "a string");
}

void ParameterReader::read(const ParameterSpec& spec, std::vector<double>& value) {
  if (!status_ || !node_ || !node_.IsMap()) return;
  const YAML::Node item = node_[spec.name];
  if (!item) return;
  if (!item.IsSequence()) {
    status_ = invalidParameter("{}{} parameter '{}' is not a list of numbers; expected {}",
                               where(item), owner_, spec.name, spec.acceptedText());
    return;
  }
  std::vector<double> parsed;
  for (const auto& element : item) {
    double v = 0;
    if (!element.IsScalar() || !YAML::convert<double>::decode(element, v)) {
      status_ = invalidParameter("{}{} parameter '{}' element '{}' is not a number", where(element),
                                 owner_, spec.name, element.IsScalar() ? element.Scalar() : "<node>");
      return;
    }
    parsed.push_back(v);
  }
  Status check = checkList(spec, parsed);
  if (!check) {
    status_ = check.withContext(fmt::format("{}{}", where(item), owner_));
    return;
  }
  value = std::move(parsed);
}

Status ParameterReader::finish(const std::vector<ParameterSpec>& specs) const {
  if (!status_ || !node_ || !node_.IsMap()) return status_;
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>("");
    const bool known = std::any_of(specs.begin(), specs.end(),
                                   [&](const ParameterSpec& s) { return s.name == key; });
    if (!known) {
      std::vector<std::string> names;
      for (const auto& s : specs) names.push_back(s.name);
      return invalidParameter("{}{} has no parameter '{}'{}; expected one of {{{}}}",
                              where(entry.first), owner_, key, suggestion(key, specs),
                              fmt::join(names, ", "));
    }
  }
  return Status::ok();
}

}  // namespace cdff::dfn
