#include "cdff/schema/field.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace cdff::schema {

namespace {

std::size_t editDistance(std::string_view a, std::string_view b) {
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

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string formatNumber(double v) {
  return fmt::format("{}", v);
}

}  // namespace

bool Range::contains(double v) const {
  if (!std::isfinite(v)) return false;
  const bool above_low = low_open ? v > low : v >= low;
  const bool below_high = high_open ? v < high : v <= high;
  return above_low && below_high;
}

std::string Range::describe(std::string_view noun) const {
  const bool has_low = std::isfinite(low), has_high = std::isfinite(high);
  std::string text(noun);
  if (has_low && has_high)
    text += fmt::format(" in {}{}, {}{}", low_open ? "(" : "[", formatNumber(low),
                        formatNumber(high), high_open ? ")" : "]");
  else if (has_low)
    text += fmt::format(" {} {}", low_open ? ">" : ">=", formatNumber(low));
  else if (has_high)
    text += fmt::format(" {} {}", high_open ? "<" : "<=", formatNumber(high));
  if (!unit.empty() && unit != "1") text += " " + unit;  // "1": dimensionless
  return text;
}

std::string nearest(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = 3;  // near misses only
  for (const std::string& c : candidates) {
    const std::size_t d = editDistance(word, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best;
}

std::string didYouMean(std::string_view word, const std::vector<std::string>& candidates) {
  const std::string best = nearest(word, candidates);
  return best.empty() ? "" : fmt::format(" (did you mean '{}'?)", best);
}

// ---------------------------------------------------------------------------------------------

Field::Field(YAML::Node node, std::string path, std::shared_ptr<const Origin> origin)
    : node_(std::move(node)), path_(std::move(path)), origin_(std::move(origin)) {}

const std::string& Field::source() const {
  static const std::string kNone;
  return origin_ ? origin_->source : kNone;
}

const char* Field::kind() const {
  switch (node_.Type()) {
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Scalar:
      return "a scalar";
    case YAML::NodeType::Null:
      return "empty";
    default:
      return "absent";
  }
}

Field Field::operator[](const std::string& key) const {
  YAML::Node child = node_.IsMap() ? node_[key] : YAML::Node(YAML::NodeType::Undefined);
  return Field(child, join(path_, key), origin_);
}

Field Field::operator[](std::size_t index) const {
  YAML::Node child = node_.IsSequence() && index < node_.size()
                         ? node_[index]
                         : YAML::Node(YAML::NodeType::Undefined);
  return Field(child, join(path_, std::to_string(index)), origin_);
}

bool Field::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

std::vector<Field> Field::elements() const {
  std::vector<Field> out;
  if (!node_.IsSequence()) return out;
  for (std::size_t i = 0; i < node_.size(); ++i) out.push_back((*this)[i]);
  return out;
}

std::vector<Field::Entry> Field::entries() const {
  std::vector<Entry> out;
  if (!node_.IsMap()) return out;
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : std::string();
    const std::string path = join(path_, key);
    out.push_back({key, Field(it->first, path, origin_), Field(it->second, path, origin_)});
  }
  return out;
}

SourceLocation Field::location() const {
  if (origin_) {
    for (const auto& [key, text] : origin_->overrides)
      if (path_ == key || path_.rfind(key + ".", 0) == 0) return {text, 0, 0};
  }
  const std::string& file = source();
  const YAML::Mark mark = node_.IsDefined() ? node_.Mark() : YAML::Mark::null_mark();
  if (mark.is_null() || mark.line < 0) return {file.empty() ? "<text>" : file, 0, 0};
  return {file.empty() ? "<text>" : file, mark.line + 1, mark.column + 1};
}

std::string Field::text() const {
  if (!node_.IsDefined() || node_.IsNull()) return "null";
  if (node_.IsScalar()) return node_.Scalar();
  // Lists and maps on one line, in flow style, whatever style the file wrote them in.
  YAML::Node flow = YAML::Clone(node_);
  flow.SetStyle(YAML::EmitterStyle::Flow);
  YAML::Emitter out;
  out << YAML::Flow << flow;
  std::string text = out.c_str();
  if (text.size() > 80) text = text.substr(0, 77) + "...";
  return text;
}

std::string Field::notA(std::string_view what) const {
  if (node_.IsScalar()) return fmt::format("not {}", what);
  return fmt::format("{}, not {}", kind(), what);
}

Status Field::fail(std::string_view expected, std::string_view problem, StatusCode code) const {
  const std::string subject = path_.empty() ? text() : fmt::format("{} = {}", path_, text());
  const std::string reason = problem.empty()
                                 ? fmt::format("{}: expected {}", subject, expected)
                                 : fmt::format("{}: {}; expected {}", subject, problem, expected);
  return Status(code, reason, location());
}

Status Field::unknownKey(const std::vector<std::string>& accepted) const {
  const std::size_t dot = path_.rfind('.');
  const std::string key = dot == std::string::npos ? path_ : path_.substr(dot + 1);
  return Status(StatusCode::kInvalidParameter,
                fmt::format("{}: unknown key; expected one of {{{}}}{}", path_,
                            fmt::join(accepted, ", "), didYouMean(key, accepted)),
                location());
}

Status Field::missing(const std::string& key, std::string_view expected) const {
  return Status(StatusCode::kInvalidParameter,
                fmt::format("{}: missing; expected {}", join(path_, key), expected), location());
}

Status Field::read(std::string& out) const {
  if (!node_.IsScalar()) return fail("a string", notA("a string"));
  out = node_.Scalar();
  return Status::ok();
}

Status Field::read(bool& out) const {
  bool v = false;
  if (!node_.IsScalar() || !YAML::convert<bool>::decode(node_, v))
    return fail("true or false", notA("a bool"));
  out = v;
  return Status::ok();
}

Status Field::read(double& out, const Range& range) const {
  double v = 0;
  if (!node_.IsScalar() || !YAML::convert<double>::decode(node_, v))
    return fail(range.describe(), notA("a number"));
  if (!std::isfinite(v)) return fail(range.describe(), "not a finite number");
  if (!range.contains(v)) return fail(range.describe(), "out of range");
  out = v;
  return Status::ok();
}

Status Field::read(int& out, int low, int high) const {
  std::int64_t v = 0;
  CDFF_RETURN_IF_ERROR(read(v, low, high));
  out = static_cast<int>(v);
  return Status::ok();
}

Status Field::read(std::int64_t& out, std::int64_t low, std::int64_t high) const {
  const auto expected = [&] {
    const bool has_low = low > std::numeric_limits<int>::min();
    const bool has_high = high < std::numeric_limits<int>::max();
    if (has_low && has_high) return fmt::format("an integer in [{}, {}]", low, high);
    if (has_low) return fmt::format("an integer >= {}", low);
    if (has_high) return fmt::format("an integer <= {}", high);
    return std::string("an integer");
  };
  long long v = 0;
  if (!node_.IsScalar() || !YAML::convert<long long>::decode(node_, v))
    return fail(expected(), notA("an integer"));
  if (v < low || v > high) return fail(expected(), "out of range");
  out = v;
  return Status::ok();
}

Status Field::read(std::uint64_t& out) const {
  std::uint64_t v = 0;
  if (!node_.IsScalar() || node_.Scalar().starts_with("-") ||
      !YAML::convert<std::uint64_t>::decode(node_, v))
    return fail("a non-negative integer", notA("a non-negative integer"));
  out = v;
  return Status::ok();
}

Status Field::choice(std::string& out, const std::vector<std::string>& choices) const {
  const std::string expected = fmt::format("one of {{{}}}", fmt::join(choices, ", "));
  if (!node_.IsScalar()) return fail(expected, notA("a name"));
  const std::string& v = node_.Scalar();
  if (std::find(choices.begin(), choices.end(), v) == choices.end())
    return fail(expected + didYouMean(v, choices), "unknown value");
  out = v;
  return Status::ok();
}

Status Field::numbers(std::vector<double>& out, std::size_t min_size, std::size_t max_size,
                      const Range& range) const {
  std::string expected =
      min_size == max_size ? fmt::format("a list of {} numbers", min_size)
      : max_size == std::numeric_limits<std::size_t>::max()
          ? (min_size == 0 ? std::string("a list of numbers")
                           : fmt::format("a list of at least {} numbers", min_size))
          : fmt::format("a list of {} to {} numbers", min_size, max_size);
  const std::string bounds = range.describe("");
  if (bounds != "") expected += "," + bounds;
  if (!node_.IsSequence()) return fail(expected, notA("a list"));
  if (node_.size() < min_size || node_.size() > max_size)
    return fail(expected, fmt::format("has {} values", node_.size()));
  std::vector<double> values;
  for (const Field& element : elements()) {
    double v = 0;
    if (!element.node_.IsScalar() || !YAML::convert<double>::decode(element.node_, v))
      return element.fail(range.describe(), element.notA("a number"));
    if (!std::isfinite(v)) return element.fail(range.describe(), "not a finite number");
    if (!range.contains(v)) return element.fail(range.describe(), "out of range");
    values.push_back(v);
  }
  out = std::move(values);
  return Status::ok();
}

Status Field::words(std::vector<std::string>& out, std::string_view expected) const {
  if (node_.IsScalar()) {
    out = {node_.Scalar()};
    return Status::ok();
  }
  if (!node_.IsSequence()) return fail(expected, notA("a list"));
  std::vector<std::string> values;
  for (const Field& element : elements()) {
    if (!element.isScalar()) return element.fail(expected, element.notA("a name"));
    values.push_back(element.node_.Scalar());
  }
  out = std::move(values);
  return Status::ok();
}

// ---------------------------------------------------------------------------------------------

Document::Document(YAML::Node root, std::string source)
    : root_(std::move(root)), origin_(std::make_shared<Origin>()) {
  origin_->source = std::move(source);
}

Document Document::of(YAML::Node root, const std::string& source) {
  return Document(std::move(root), source);
}

Result<Document> Document::loadFile(const std::string& path, std::string_view what) {
  try {
    return Document(YAML::LoadFile(path), path);
  } catch (const YAML::BadFile&) {
    return notFound("{}: cannot open {}; expected a readable YAML file", path, what);
  } catch (const YAML::Exception& e) {
    return Status(StatusCode::kInvalidParameter, fmt::format("YAML syntax error: {}", e.msg),
                  {path, e.mark.line + 1, e.mark.column + 1});
  }
}

Result<Document> Document::parse(const std::string& text, const std::string& source) {
  try {
    return Document(YAML::Load(text), source);
  } catch (const YAML::Exception& e) {
    return Status(StatusCode::kInvalidParameter, fmt::format("YAML syntax error: {}", e.msg),
                  {source, e.mark.line + 1, e.mark.column + 1});
  }
}

void Document::setOverride(const std::string& key_path, const std::string& origin_text) {
  origin_->overrides[key_path] = origin_text;
}

}  // namespace cdff::schema
