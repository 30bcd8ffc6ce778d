#include "cdff/dfn/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <fmt/format.h>

namespace cdff::dfn {

double inUnits(double value, std::string_view unit, ParameterUnits units) {
  const double factor = siPerUnit(unit);
  if (units == ParameterUnits::kSi || factor == 1.0) return value;
  // The shortest decimal that the reader turns back into the same C++ value: the YAML shows 30,
  // not 29.999999999999996, and configure() takes it back unchanged.
  const double in_unit = value / factor;
  for (int digits = 1; digits <= std::numeric_limits<double>::max_digits10; ++digits) {
    const double shorter = std::strtod(fmt::format("{:.{}g}", in_unit, digits).c_str(), nullptr);
    if (shorter * factor == value) return shorter;
  }
  return in_unit;
}

std::vector<double> inUnits(const std::vector<double>& values, std::string_view unit,
                            ParameterUnits units) {
  std::vector<double> out;
  out.reserve(values.size());
  for (double v : values) out.push_back(inUnits(v, unit, units));
  return out;
}

ParameterReader::ParameterReader(const YAML::Node& node, std::string source, std::string owner,
                                 ParameterUnits units)
    : root_(schema::Document::of(node, source).root()), owner_(std::move(owner)), units_(units) {
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

schema::Range ParameterReader::rangeOf(const ParameterSpec& spec) const {
  // SI values are checked against the bounds in SI: the C++ value itself, not a conversion of
  // it, is what the message shows.
  const double scale = units_ == ParameterUnits::kSi ? siPerUnit(spec.unit) : 1.0;
  schema::Range r;
  if (spec.min) r.low = *spec.min * scale;
  if (spec.max) r.high = *spec.max * scale;
  r.unit = units_ == ParameterUnits::kSi ? siUnit(spec.unit) : spec.unit;
  return r;
}

double ParameterReader::factorOf(const ParameterSpec& spec) const {
  return units_ == ParameterUnits::kSi ? 1.0 : siPerUnit(spec.unit);
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
  auto f = given(spec);
  if (!f) return;
  double v = 0;
  const Status s = f->read(v, rangeOf(spec));
  keep(s);
  if (s) value = v * factorOf(spec);
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
  std::vector<double> v;
  const Status s = f->numbers(v, min, max, rangeOf(spec));
  keep(s);
  if (!s) return;
  const double factor = factorOf(spec);
  for (double& x : v) x *= factor;
  value = std::move(v);
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
