#pragma once
// Reading the JSON report of `cdff eval --json` and a recording's events in end-to-end tests.
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "support/command.hpp"

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

/// Stream time (s) of the first change of DFPC `dfpc`'s track state to TRACKING, from the
/// recording's events (`cdff log cat`); -1 if never.
inline double firstTracking(const std::string& recording, const std::string& dfpc) {
  const CommandResult r = runCdff(fmt::format("log cat {} -c /cdff/events", recording));
  std::istringstream lines(r.output);
  std::string line;
  while (std::getline(lines, line)) {
    const nlohmann::json event = nlohmann::json::parse(line, nullptr, false);
    if (event.is_discarded() || !event.contains("data")) continue;
    const nlohmann::json& d = event["data"];
    if (d.value("dfpc", "") == dfpc && d.value("type", "") == "track_state_changed" &&
        d.value("message", "").ends_with("-> TRACKING"))
      return event["log_time"].get<double>();
  }
  return -1;
}

}  // namespace cdff::testing
