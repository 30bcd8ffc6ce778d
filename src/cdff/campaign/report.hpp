#pragma once
// A campaign's report (docs/campaigns.md): per requirement, the fraction of runs that pass with
// its Clopper-Pearson confidence interval and the distribution of the measured values over the
// runs; per pose product, the distribution of each run's accuracy figures; the failed runs and
// the worst ones, each with the command that reproduces it.

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/campaign/campaign.hpp"

namespace cdff::campaign {

/// The exact (Clopper-Pearson) two-sided interval of a binomial proportion: `successes` of
/// `trials`, at `confidence` (e.g. 0.95). trials > 0.
std::pair<double, double> clopperPearson(std::uint64_t successes, std::uint64_t trials,
                                         double confidence = 0.95);

/// p-th percentile (0..100) of `values` by linear interpolation between order statistics.
double percentile(std::vector<double> values, double p);

/// Reads every result.json of `results` and aggregates them (runs not done yet are counted as
/// missing).
Result<nlohmann::json> campaignReport(const Campaign& campaign,
                                      const std::filesystem::path& results);

/// The report as text for a terminal.
std::string reportText(const nlohmann::json& report);
/// The report as a self-contained HTML page (tables and inline SVG plots).
std::string reportHtml(const nlohmann::json& report);

}  // namespace cdff::campaign
