#pragma once
// Reading YAML against a schema, with one error format for every file the project reads (DFN
// descriptions, DFN parameters, DFPC graphs, scenarios):
//
//   <file>:<line>:<column>: <key path> = <value>: <problem>; expected <what> (did you mean 'x'?)
//
// A Field is a YAML node with its key path ("sensors.lidar.range_noise") and the document it
// came from, so that every error says where, which key, which value and what was expected, and
// carries its location as data (Status::location()). Declarative tables of the fields of a map
// are in table.hpp.

#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/types/status.hpp"

namespace cdff::schema {

/// Where a document's text came from, and the keys whose values were set from elsewhere (a
/// scenario's `--set key=value`): their errors name the override instead of a line.
struct Origin {
  std::string source;                            // file path, or a name such as "<inline>"
  std::map<std::string, std::string> overrides;  // key path -> where it was set ("--set a.b=1")
};

/// The accepted range of a number: [low, high], either end open or absent; `unit` for messages.
struct Range {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_open = false;
  bool high_open = false;
  std::string unit;

  static Range atLeast(double low, std::string unit = {}) {
    return {low, kInf, false, false, unit};
  }
  static Range above(double low, std::string unit = {}) { return {low, kInf, true, false, unit}; }
  static Range closed(double low, double high, std::string unit = {}) {
    return {low, high, false, false, std::move(unit)};
  }
  /// (low, high]
  static Range leftOpen(double low, double high, std::string unit = {}) {
    return {low, high, true, false, std::move(unit)};
  }
  bool contains(double v) const;
  /// "a number in [0, 1] m", "a number >= 0", "a number > 0 s", "a number".
  std::string describe(std::string_view noun = "a number") const;

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
};

/// The nearest of `candidates` to `word` by edit distance, when it is a near miss (at most 2
/// edits); "" otherwise.
std::string nearest(std::string_view word, const std::vector<std::string>& candidates);
/// " (did you mean 'x'?)" for the nearest candidate, or "".
std::string didYouMean(std::string_view word, const std::vector<std::string>& candidates);

class Field {
 public:
  Field() = default;
  Field(YAML::Node node, std::string path, std::shared_ptr<const Origin> origin);

  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  const std::shared_ptr<const Origin>& origin() const { return origin_; }
  const std::string& source() const;

  /// Present and not null.
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool isMap() const { return node_.IsMap(); }
  bool isList() const { return node_.IsSequence(); }
  bool isScalar() const { return node_.IsScalar(); }
  /// "a map", "a list", "a scalar", "empty".
  const char* kind() const;
  std::size_t size() const { return node_.size(); }

  /// The child `key` of a map (undefined when absent or when this is not a map).
  Field operator[](const std::string& key) const;
  /// Element `index` of a list, path "<path>.<index>".
  Field operator[](std::size_t index) const;
  bool has(const std::string& key) const;
  /// A list's elements.
  std::vector<Field> elements() const;
  /// A map's entries in file order: (key, value), the key as a Field too (for its location).
  struct Entry;
  std::vector<Entry> entries() const;

  /// Where the node is: the override that set it, or file:line:column.
  SourceLocation location() const;
  /// The value as written (flow YAML for maps and lists), "null" when absent.
  std::string text() const;

  /// The one error format: "<path> = <value>: <problem>; expected <expected>" at location().
  /// An empty problem gives "<path> = <value>: expected <expected>".
  /// "not a number" for a scalar, "a list, not a number" for a list or map: the problem part of
  /// a type error.
  std::string notA(std::string_view what) const;
  Status fail(std::string_view expected, std::string_view problem = {},
              StatusCode code = StatusCode::kInvalidParameter) const;
  /// "<path>: unknown key; expected one of {...} (did you mean 'x'?)", at the key.
  Status unknownKey(const std::vector<std::string>& accepted) const;
  /// "<path>.<key>: missing; expected <expected>", at this map.
  Status missing(const std::string& key, std::string_view expected) const;

  // Typed reads of a present scalar (or list); each fails with the one error format.
  Status read(std::string& out) const;
  Status read(bool& out) const;
  Status read(double& out, const Range& range = {}) const;
  Status read(int& out, int low = std::numeric_limits<int>::min(),
              int high = std::numeric_limits<int>::max()) const;
  Status read(std::int64_t& out, std::int64_t low, std::int64_t high) const;
  Status read(std::uint64_t& out) const;
  /// One of `choices`.
  Status choice(std::string& out, const std::vector<std::string>& choices) const;
  /// A list of min_size..max_size finite numbers, each within `range`.
  Status numbers(std::vector<double>& out, std::size_t min_size, std::size_t max_size,
                 const Range& range = {}) const;
  /// A scalar, or a list of scalars: a list of strings.
  Status words(std::vector<std::string>& out, std::string_view expected) const;

 private:
  YAML::Node node_;
  std::string path_;
  std::shared_ptr<const Origin> origin_;
};

struct Field::Entry {
  std::string key;
  Field key_field;
  Field value;
};

/// A parsed YAML document with its origin.
class Document {
 public:
  Document() : Document(YAML::Node(), "") {}
  /// Reads a file; a missing file is kNotFound ("<path>: cannot open <what>; expected a readable
  /// YAML file"), a syntax error kInvalidParameter at its line and column.
  static Result<Document> loadFile(const std::string& path, std::string_view what);
  /// Parses text; `source` names it in messages.
  static Result<Document> parse(const std::string& text, const std::string& source);
  /// A document over an existing node (e.g. parameters given inline in C++).
  static Document of(YAML::Node root, const std::string& source);

  Field root() const { return Field(root_, "", origin_); }
  YAML::Node& node() { return root_; }
  const std::string& source() const { return origin_->source; }
  /// Records that `key_path` (and everything below it) was set by `origin_text`.
  void setOverride(const std::string& key_path, const std::string& origin_text);

 private:
  Document(YAML::Node root, std::string source);
  YAML::Node root_;
  std::shared_ptr<Origin> origin_;
};

}  // namespace cdff::schema
