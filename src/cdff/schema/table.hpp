#pragma once
// Declarative tables of the fields of a YAML map:
//
//   const schema::Table<DfpcInputSpec> kInput = schema::Table<DfpcInputSpec>("a DFPC input")
//       .required("name", schema::text(&DfpcInputSpec::name), "an identifier")
//       .required("type", schema::text(&DfpcInputSpec::type), "a data type name")
//       .optional("optional", schema::flag(&DfpcInputSpec::optional));
//   CDFF_RETURN_IF_ERROR(kInput.read(field, input));
//
// read() checks the whole map first (a map; every key known, else the accepted keys and the
// nearest one; no key twice; every required key present), then reads the present keys in the
// table's order, stopping at the first error. Readers are plain functions of (Field, Target&),
// so a field with rules of its own (a file reference, a choice that sets an enum) is a lambda.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "cdff/schema/field.hpp"

namespace cdff::schema {

template <typename Target>
class Table {
 public:
  using Reader = std::function<Status(const Field&, Target&)>;

  explicit Table(std::string what) : what_(std::move(what)) {}

  Table& required(std::string key, Reader read, std::string expected) {
    rows_.push_back({std::move(key), std::move(read), true, std::move(expected)});
    return *this;
  }
  Table& optional(std::string key, Reader read) {
    rows_.push_back({std::move(key), std::move(read), false, {}});
    return *this;
  }

  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (const Row& r : rows_) out.push_back(r.key);
    return out;
  }

  /// Checks the map's keys (see the file comment) without reading the values.
  Status check(const Field& map) const {
    if (!map.isMap()) return map.fail(fmt::format("{} (a map of key: value)", what_));
    const std::vector<std::string> accepted = keys();
    std::vector<std::string> seen;
    for (const Field::Entry& e : map.entries()) {
      if (std::find(accepted.begin(), accepted.end(), e.key) == accepted.end())
        return e.key_field.unknownKey(accepted);
      if (std::find(seen.begin(), seen.end(), e.key) != seen.end())
        return Status(StatusCode::kInvalidParameter,
                      fmt::format("{}: given twice; expected each key once", e.key_field.path()),
                      e.key_field.location());
      seen.push_back(e.key);
    }
    for (const Row& r : rows_)
      if (r.required && !map.has(r.key)) return map.missing(r.key, r.expected);
    return Status::ok();
  }

  Status read(const Field& map, Target& out) const {
    CDFF_RETURN_IF_ERROR(check(map));
    for (const Row& r : rows_) {
      const Field value = map[r.key];
      if (value.defined()) CDFF_RETURN_IF_ERROR(r.read(value, out));
    }
    return Status::ok();
  }

 private:
  struct Row {
    std::string key;
    Reader read;
    bool required;
    std::string expected;
  };
  std::string what_;
  std::vector<Row> rows_;
};

// Readers of one member each.

template <typename T>
auto text(std::string T::*member) {
  return [member](const Field& f, T& out) { return f.read(out.*member); };
}
template <typename T>
auto flag(bool T::*member) {
  return [member](const Field& f, T& out) { return f.read(out.*member); };
}
template <typename T>
auto number(double T::*member, Range range = {}) {
  return [member, range](const Field& f, T& out) { return f.read(out.*member, range); };
}
template <typename T>
auto integer(int T::*member, int low, int high = std::numeric_limits<int>::max()) {
  return [member, low, high](const Field& f, T& out) { return f.read(out.*member, low, high); };
}
template <typename T>
auto oneOf(std::string T::*member, std::vector<std::string> choices) {
  return [member, choices = std::move(choices)](const Field& f, T& out) {
    return f.choice(out.*member, choices);
  };
}
/// A string choice mapped onto a value (an enum): {{"exact", kExact}, {"nearest", kNearest}}.
template <typename T, typename Value>
auto named(Value T::*member, std::vector<std::pair<std::string, Value>> names) {
  return [member, names = std::move(names)](const Field& f, T& out) -> Status {
    std::vector<std::string> words;
    for (const auto& [word, value] : names) words.push_back(word);
    std::string chosen;
    CDFF_RETURN_IF_ERROR(f.choice(chosen, words));
    for (const auto& [word, value] : names)
      if (word == chosen) out.*member = value;
    return Status::ok();
  };
}
/// A nested map read by its own table.
template <typename T, typename Inner>
auto nested(Inner T::*member, const Table<Inner>& table) {
  return [member, &table](const Field& f, T& out) { return table.read(f, out.*member); };
}
/// A list whose elements each are read by `table`.
template <typename T, typename Element>
auto listOf(std::vector<Element> T::*member, const Table<Element>& table, std::string what) {
  return [member, &table, what = std::move(what)](const Field& f, T& out) -> Status {
    if (!f.isList()) return f.fail(fmt::format("a list of {}", what));
    std::vector<Element> items;
    for (const Field& element : f.elements()) {
      Element item{};
      CDFF_RETURN_IF_ERROR(table.read(element, item));
      items.push_back(std::move(item));
    }
    out.*member = std::move(items);
    return Status::ok();
  };
}

}  // namespace cdff::schema
