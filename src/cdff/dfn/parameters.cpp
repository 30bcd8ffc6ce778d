#include "cdff/dfn/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace cdff::dfn {

namespace {

schema::Range rangeOf(const ParameterSpec& spec) {
  schema::Range r;
  if (spec.min) r.low = *spec.min;
  if (spec.max) r.high = *spec.max;
  r.unit = spec.unit;
  return r;
}

}  // namespace

ParameterReader::ParameterReader(const YAML::Node& node, std::string source, std::string owner)
    : root_(schema::Document::of(node, source).root()), owner_(std::move(owner)) {
  if (node && !node.IsNull() && !node.IsMap())
    status_ =
        root_.fail("a map of parameter: value", fmt::format("parameters are {}", root_.kind()))
            .withContext(owner_);
}

std::optional<schema::Field> ParameterReader::given(const ParameterSpec& spec) const {
  if (!status_ || !root_.isMap()) return std::nullopt;
  schema::Field f = root_[spec.name];
  if (!f.node().IsDefined()) return std::nullopt;  // keep the default
  return f;
}

void ParameterReader::keep(Status status) {
  if (!status) status_ = status.withContext(owner_);
}

void ParameterReader::read(const ParameterSpec& spec, bool& value) {
  if (auto f = given(spec)) keep(f->read(value));
}

void ParameterReader::read(const ParameterSpec& spec, int& value) {
  auto f = given(spec);
  if (!f) return;
  const auto bound = [](const std::optional<double>& b, std::int64_t fallback) {
    return b ? static_cast<std::int64_t>(*b) : fallback;
  };
  std::int64_t v = 0;
  const Status s = f->read(v, bound(spec.min, std::numeric_limits<int>::min()),
                           bound(spec.max, std::numeric_limits<int>::max()));
  keep(s);
  if (s) value = static_cast<int>(v);
}

void ParameterReader::read(const ParameterSpec& spec, double& value) {
  if (auto f = given(spec)) keep(f->read(value, rangeOf(spec)));
}

void ParameterReader::read(const ParameterSpec& spec, std::string& value) {
  auto f = given(spec);
  if (!f) return;
  keep(spec.allowed.empty() ? f->read(value) : f->choice(value, spec.allowed));
}

void ParameterReader::read(const ParameterSpec& spec, std::vector<double>& value) {
  auto f = given(spec);
  if (!f) return;
  const std::size_t min = spec.list_size ? *spec.list_size : 0;
  const std::size_t max =
      spec.list_size ? *spec.list_size : std::numeric_limits<std::size_t>::max();
  keep(f->numbers(value, min, max, rangeOf(spec)));
}

Status ParameterReader::finish(const std::vector<ParameterSpec>& specs) const {
  if (!status_ || !root_.isMap()) return status_;
  std::vector<std::string> names;
  for (const auto& s : specs) names.push_back(s.name);
  for (const schema::Field::Entry& e : root_.entries())
    if (std::find(names.begin(), names.end(), e.key) == names.end())
      return e.key_field.unknownKey(names).withContext(owner_);
  return Status::ok();
}

}  // namespace cdff::dfn
