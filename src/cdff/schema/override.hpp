#pragma once
// Command-line overrides of a YAML document's keys (`cdff sim --set sensors.lidar.rate=5`,
// `cdff run --set icp.max_iterations=30`): KEY=VALUE, the key dotted, list items by index
// (faults.0.start=5), the value YAML ("[1, 2]", "true", "0.5"). The document remembers which
// keys were overridden, so that an error in an overridden value names the override instead of a
// line of the file.
#include <string>
#include <string_view>

#include "cdff/schema/field.hpp"

namespace cdff::schema {

/// The parts of "KEY=VALUE": the key's dotted parts (none empty) and the value's text.
struct Override {
  std::string text;  // as given
  std::vector<std::string> key;
  std::string value;
};

/// Splits `text`; `example` is shown when the text is not KEY=VALUE.
Result<Override> parseOverride(const std::string& text, std::string_view example);

/// Sets the override in `document` under `prefix` (dotted parts before the override's key):
/// maps are created on the way, list items are indexed by number.
Status applyOverride(Document& document, const Override& o,
                     const std::vector<std::string>& prefix = {});

}  // namespace cdff::schema
