// KEY=VALUE overrides of a YAML document (override.hpp).
#include "cdff/schema/override.hpp"

#include <cstdlib>
#include <sstream>

#include <fmt/format.h>

namespace cdff::schema {

namespace {

/// Where an override's errors point: the override itself, as the command line gave it.
Status overrideError(const std::string& text, std::string reason) {
  return Status(StatusCode::kInvalidParameter, std::move(reason),
                SourceLocation{"--set " + text, 0, 0});
}

std::string joined(const std::vector<std::string>& parts) {
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ".") + p;
  return out;
}

}  // namespace

Result<Override> parseOverride(const std::string& text, std::string_view example) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    return overrideError(text,
                         fmt::format("expected KEY=VALUE with a dotted key, e.g. {}", example));
  Override o;
  o.text = text;
  o.value = text.substr(eq + 1);
  const std::string key = text.substr(0, eq);
  std::stringstream ss(key);
  for (std::string part; std::getline(ss, part, '.');) {
    if (part.empty())
      return overrideError(text, fmt::format("the key '{}' has an empty part", key));
    o.key.push_back(part);
  }
  if (key.back() == '.')
    return overrideError(text, fmt::format("the key '{}' has an empty part", key));
  return o;
}

Status applyOverride(Document& document, const Override& o,
                     const std::vector<std::string>& prefix) {
  YAML::Node value;
  try {
    value = YAML::Load(o.value);
  } catch (const YAML::Exception& e) {
    return overrideError(o.text,
                         fmt::format("the value '{}' is not valid YAML: {}", o.value, e.msg));
  }
  std::vector<std::string> parts = prefix;
  parts.insert(parts.end(), o.key.begin(), o.key.end());
  YAML::Node& root = document.node();
  if (!root.IsDefined() || root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  YAML::Node current = root;
  std::string walked;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string& part = parts[i];
    const bool last = i + 1 == parts.size();
    const std::string parent = walked;
    walked += (walked.empty() ? "" : ".") + part;
    if (current.IsSequence()) {
      char* end = nullptr;
      const long index = std::strtol(part.c_str(), &end, 10);
      if (*end != '\0' || index < 0 || static_cast<std::size_t>(index) >= current.size())
        return overrideError(
            o.text, fmt::format("'{}' indexes a list of {} items; expected 0 to {}", walked,
                                current.size(), static_cast<long>(current.size()) - 1));
      if (last) {
        current[static_cast<std::size_t>(index)] = value;
      } else {
        YAML::Node next = current[static_cast<std::size_t>(index)];
        current.reset(next);
      }
      continue;
    }
    if (!current.IsMap() && !current.IsNull() && current.IsDefined())
      return overrideError(o.text, fmt::format("'{}' is a value, not a mapping with keys", parent));
    if (last) {
      current[part] = value;
    } else {
      if (!current[part].IsDefined() || current[part].IsNull())
        current[part] = YAML::Node(YAML::NodeType::Map);
      YAML::Node next = current[part];
      current.reset(next);
    }
  }
  document.setOverride(joined(parts), "--set " + o.text);
  return Status::ok();
}

}  // namespace cdff::schema
