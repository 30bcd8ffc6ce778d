#pragma once
// One run of a campaign: simulate its scenario with its draw and dispersions, run the DFPC
// graphs over the recording, evaluate their products against the truth, and write the result
// (result.json) in the run's folder. A run that fails says at which stage and why; it is a
// result too, never lost.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "cdff/campaign/campaign.hpp"

namespace cdff::campaign {

/// The run's folder under a results folder: DIR/runs/000042.
std::filesystem::path runDirectory(const std::filesystem::path& results, std::uint64_t index);
/// DIR/runs/000042/result.json.
std::filesystem::path resultFile(const std::filesystem::path& results, std::uint64_t index);

/// Executes run `index` in this process and writes its result.json (atomically: a result file
/// is complete or absent). Returns the result written; an error only when it could not be
/// written.
Result<nlohmann::json> executeRun(const Campaign& campaign, std::uint64_t index,
                                  const std::filesystem::path& results);

/// Writes `result` as run `index`'s result.json, atomically.
Status writeResult(const std::filesystem::path& results, std::uint64_t index,
                   const nlohmann::json& result);

}  // namespace cdff::campaign
