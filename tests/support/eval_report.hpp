#pragma once
// Reading the JSON report of `cdff eval --json` in end-to-end tests.
#include <string>

#include <nlohmann/json.hpp>

namespace cdff::testing {

/// The entry of `products` for `channel`, or null when the report has none.
inline const nlohmann::json* reportProduct(const nlohmann::json& report,
                                           const std::string& channel) {
  for (const nlohmann::json& p : report.at("products"))
    if (p.at("channel") == channel) return &p;
  return nullptr;
}

}  // namespace cdff::testing
