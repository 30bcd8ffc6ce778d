#pragma once
// Reading the JSON report of `cdff eval --json` in end-to-end tests.
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace cdff::testing {

/// The report `cdff eval --json PATH` wrote (a discarded value when it is not JSON).
inline nlohmann::json readReport(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file, nullptr, false);
}

/// The entry of `products` for `channel`, or null when the report has none.
inline const nlohmann::json* reportProduct(const nlohmann::json& report,
                                           const std::string& channel) {
  for (const nlohmann::json& p : report.at("products"))
    if (p.at("channel") == channel) return &p;
  return nullptr;
}

}  // namespace cdff::testing
