// The campaign library: reading and checking campaign files (errors at file:line with the key),
// reproducible and independent draws, the Clopper-Pearson interval against published values,
// and the local pool retrying, then recording, a run whose process crashes.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include <nlohmann/json.hpp>

#include "cdff/campaign/campaign.hpp"
#include "cdff/campaign/pool.hpp"
#include "cdff/campaign/report.hpp"
#include "cdff/campaign/run.hpp"

namespace cdff::campaign {
namespace {

namespace fs = std::filesystem;

const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/lidar_tracking.yaml";

std::string campaignText(const std::string& dispersions = "") {
  return "name: t\nruns: 5\nscenarios:\n  - {name: mid_range_approach, duration: 2}\n" +
         (dispersions.empty() ? std::string() : "dispersions:\n" + dispersions) +
         "dfpcs:\n  - graph: " + kGraph + "\n";
}

TEST(CampaignFile, ReadsScenariosDispersionsAndGraphs) {
  Result<Campaign> c =
      parseCampaign(campaignText("  - {key: sensors.lidar.range_noise, uniform: [0.01, 0.03]}\n"
                                 "  - {key: target.attitude.rpy_deg.0, normal: [10, 5]}\n"
                                 "  - {key: lighting.sun.preset, choice: [side_lit, front_lit]}\n"),
                    "c.yaml");
  ASSERT_TRUE(c) << c.status().message();
  EXPECT_EQ(c->runs, 5u);
  EXPECT_EQ(c->first_draw, 1'000'001u);  // after the tuning draws
  ASSERT_EQ(c->dispersions.size(), 3u);
  EXPECT_EQ(c->dispersions[2].values, (std::vector<std::string>{"side_lit", "front_lit"}));
  EXPECT_TRUE(checkCampaign(*c).isOk()) << checkCampaign(*c).message();
}

// A run set as a campaign's graph: its graphs, settings, maps and rules are checked as a run
// loads them (the graphs' model files are relative to the repository).
TEST(CampaignFile, ARunSetIsCheckedAsARunLoadsIt) {
  fs::current_path(CDFF_SOURCE_DIR);
  std::string text = campaignText();
  text.replace(text.find(kGraph), kGraph.size(), "dfpcs/rendezvous.yaml");
  Result<Campaign> c = parseCampaign(text, "c.yaml");
  ASSERT_TRUE(c) << c.status().message();
  EXPECT_TRUE(checkCampaign(*c).isOk()) << checkCampaign(*c).message();
  c->dfpcs[0].settings = {"nobody.max_iterations=3"};
  const std::string message = checkCampaign(*c).message();
  EXPECT_NE(message.find("dfpcs/rendezvous.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("node 'nobody'"), std::string::npos) << message;
}

TEST(CampaignFile, ErrorsNameTheFileLineAndKey) {
  auto error = [](const std::string& text) {
    Result<Campaign> c = parseCampaign(text, "c.yaml");
    return c ? checkCampaign(*c).message() : c.status().message();
  };
  // a dispersed key the scenario does not have: at the dispersion's line, with the near miss
  EXPECT_EQ(error(campaignText("  - {key: sensors.lidar.range_nois, uniform: [0.01, 0.02]}\n"))
                .rfind("c.yaml:6:5: dispersion 'sensors.lidar.range_nois'", 0),
            0u);
  EXPECT_NE(error(campaignText("  - {key: sensors.lidar.range_nois, uniform: [0.01, 0.02]}\n"))
                .find("did you mean 'range_noise'?"),
            std::string::npos);
  // a value the scenario refuses, found at the distribution's extreme
  EXPECT_NE(error(campaignText("  - {key: sensors.lidar.range_noise, uniform: [-1, 0.02]}\n"))
                .find("range_noise=-1"),
            std::string::npos);
  std::string text = campaignText();
  EXPECT_NE(error(std::string(text).replace(text.find("runs: 5"), 7, "runs: -5"))
                .find("c.yaml:2:7: runs = -5: out of range"),
            std::string::npos);
  EXPECT_NE(error(std::string(text).replace(text.find("runs: 5"), 7, "runs: 5\nfirst_draws: 3"))
                .find("did you mean 'first_draw'?"),
            std::string::npos);
  EXPECT_NE(error(campaignText("  - {key: a.b, uniform: [2, 1]}\n")).find("low <= high"),
            std::string::npos);
  EXPECT_NE(error(campaignText("  - {key: a.b}\n")).find("no distribution"), std::string::npos);
  EXPECT_NE(error(campaignText("  - {key: a.b, uniform: [0, 1], normal: [0, 1]}\n"))
                .find("several distributions"),
            std::string::npos);
}

TEST(RunPlan, EachRunIsItsDrawAndEachDispersionItsOwnStream) {
  const std::string noise = "  - {key: sensors.lidar.range_noise, uniform: [0.01, 0.03]}\n";
  const std::string yaw = "  - {key: target.attitude.rpy_deg.2, uniform: [-180, 180]}\n";
  Result<Campaign> one = parseCampaign(campaignText(noise), "a.yaml");
  Result<Campaign> two = parseCampaign(campaignText(yaw + noise), "b.yaml");
  ASSERT_TRUE(one && two);
  const RunPlan a = planRun(*one, 3), b = planRun(*two, 3), again = planRun(*one, 3);
  EXPECT_EQ(a.draw, one->first_draw + 3);
  EXPECT_EQ(a.dispersed, again.dispersed);  // reproducible from (campaign, index)
  // adding a dispersion leaves the others' values as they were
  EXPECT_EQ(a.dispersed[0], b.dispersed[1]);
  EXPECT_NE(planRun(*one, 4).dispersed[0].second, a.dispersed[0].second);
  // the uniform's values over many runs stay in range and fill it
  double low = 1, high = 0;
  for (std::uint64_t i = 0; i < 200; ++i) {
    const double v = std::stod(planRun(*one, i).dispersed[0].second);
    low = std::min(low, v);
    high = std::max(high, v);
  }
  EXPECT_GE(low, 0.01);
  EXPECT_LE(high, 0.03);
  EXPECT_LT(low, 0.0102);
  EXPECT_GT(high, 0.0298);
}

// Scenario entries with faults of their own: an entry's dispersions are drawn for its runs only,
// after the campaign's, and may draw its own faults' sizes; entries of one scenario need labels.
constexpr const char* kFaultEntries = R"(name: t
runs: 4
scenarios:
  - {name: mid_range_approach, duration: 2}
  - name: mid_range_approach
    label: occluded
    duration: 2
    set: {faults: [{type: occlusion, sensor: "*", start: 1, end: 2}]}
    dispersions:
      - {key: faults.0.fraction, choice: [0.25, 0.75]}
dispersions:
  - {key: sensors.lidar.range_noise, uniform: [0.01, 0.03]}
dfpcs:
  - graph: GRAPH
    pair: /chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image
    initial_state: {channel: /x, at: /chaser/camera/left/image, truth: /truth/camera_left/target_pose,
                    velocity_sigma: 0.05, angular_velocity_sigma_deg: 2}
)";

std::string faultEntries() {
  std::string text = kFaultEntries;
  return text.replace(text.find("GRAPH"), 5, kGraph);
}

TEST(CampaignFile, AScenarioEntryDrawsItsOwnDispersionsAfterTheCampaigns) {
  Result<Campaign> c = parseCampaign(faultEntries(), "f.yaml");
  ASSERT_TRUE(c) << c.status().message();
  EXPECT_EQ(c->scenarios[0].label, "mid_range_approach");  // by default, the name
  EXPECT_EQ(c->scenarios[1].label, "occluded");
  EXPECT_TRUE(checkCampaign(*c).isOk()) << checkCampaign(*c).message();
  const RunPlan nominal = planRun(*c, 2), occluded = planRun(*c, 3);
  ASSERT_EQ(nominal.dispersed.size(), 1u);
  ASSERT_EQ(occluded.dispersed.size(), 2u);
  EXPECT_EQ(occluded.dispersed[1].first, "faults.0.fraction");
  EXPECT_TRUE(occluded.dispersed[1].second == "0.25" || occluded.dispersed[1].second == "0.75");
  EXPECT_EQ(occluded.overrides.back(), "faults.0.fraction=" + occluded.dispersed[1].second);
  // the command that reproduces a run carries the entry's faults, its drawn size, the pairs and
  // the initial state's truth and sigmas
  const std::string command = reproduceCommand(*c, occluded);
  for (const char* part : {"--set 'faults=[{type: occlusion", "--set faults.0.fraction=0.",
                           "--pair /chaser/stereo/pair=/chaser/camera/left/image,",
                           "--truth /truth/camera_left/target_pose", "--velocity-sigma 0.05",
                           "--angular-velocity-sigma-deg 2"})
    EXPECT_NE(command.find(part), std::string::npos) << part << " not in " << command;
}

TEST(CampaignFile, ScenarioEntryErrorsNameTheirPlace) {
  auto error = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    Result<Campaign> c = parseCampaign(text, "f.yaml");
    return c ? checkCampaign(*c).message() : c.status().message();
  };
  const std::string text = faultEntries();
  // two entries of one scenario without labels
  EXPECT_NE(error(text, "    label: occluded\n", "").find("f.yaml:5:5: scenarios.1"),
            std::string::npos);
  EXPECT_NE(error(text, "    label: occluded\n", "").find("add label"), std::string::npos);
  // an entry's key the campaign disperses already
  EXPECT_NE(error(text, "faults.0.fraction, choice: [0.25, 0.75]",
                  "sensors.lidar.range_noise, uniform: [0, 1]")
                .find("f.yaml:10:9: dispersions: 'sensors.lidar.range_noise' is dispersed for "
                      "every scenario already (line 12)"),
            std::string::npos);
  // a fault key dispersed where the scenario has no fault: at the entry's dispersion
  EXPECT_NE(
      error(text, "    set: {faults: [{type: occlusion, sensor: \"*\", start: 1, end: 2}]}\n", "")
          .find("f.yaml:9:9: dispersion 'faults.0.fraction' of scenario "
                "'mid_range_approach'"),
      std::string::npos);
  // a pair and a run-while rule as `cdff run` would refuse them, at their line
  EXPECT_EQ(error(text, "pair: /chaser/stereo/pair=", "pair: /chaser/stereo/pair")
                .rfind("f.yaml:15:11: stereo pairing '/chaser/stereo/pair/chaser", 0),
            0u);
  EXPECT_EQ(error(text, "    pair:", "    run_while: detection=tracker:SOMETIMES\n    pair:")
                .rfind("f.yaml:15:16: run-while rule 'detection=tracker:SOMETIMES': 'SOMETIMES' is "
                       "not a track state",
                       0),
            0u);
}

TEST(Statistics, ClopperPearsonMatchesPublishedValues) {
  // Exact binomial intervals (e.g. the tables of Clopper and Pearson 1934, or R's binom.test)
  auto [l0, h0] = clopperPearson(0, 20);
  EXPECT_DOUBLE_EQ(l0, 0.0);
  EXPECT_NEAR(h0, 0.16843, 1e-5);
  auto [l1, h1] = clopperPearson(20, 20);
  EXPECT_NEAR(l1, 0.83157, 1e-5);
  EXPECT_DOUBLE_EQ(h1, 1.0);
  auto [l2, h2] = clopperPearson(5, 10);
  EXPECT_NEAR(l2, 0.18709, 1e-5);
  EXPECT_NEAR(h2, 0.81291, 1e-5);
  auto [l3, h3] = clopperPearson(16, 20);
  EXPECT_NEAR(l3, 0.56339, 1e-5);
  EXPECT_NEAR(h3, 0.94267, 1e-5);
}

TEST(Statistics, PercentileInterpolatesBetweenOrderStatistics) {
  EXPECT_DOUBLE_EQ(percentile({3, 1, 2}, 50), 2);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 50), 2.5);
  EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4}, 100), 4);
  EXPECT_DOUBLE_EQ(percentile({7}, 95), 7);
}

// The report from results written by hand: per requirement, a run without a pose fails what
// applied to its entry's other runs; per scenario entry, its runs by outcome and its figures.
TEST(Report, GathersRequirementsAndScenarioEntries) {
  Result<Campaign> c = parseCampaign(faultEntries(), "f.yaml");
  ASSERT_TRUE(c) << c.status().message();
  const fs::path dir = fs::temp_directory_path() / "cdff_campaign_report_test";
  fs::remove_all(dir);
  ASSERT_TRUE(prepareResults(*c, dir).isOk());
  auto evaluated = [](double p95_m, bool faults) {
    const std::string verdict = p95_m < 1.0 ? "pass" : "fail";
    return nlohmann::json{{"status", "ok"},
                          {"dfpcs", {{{"name", "t"}, {"faults", faults ? 3 : 0}}}},
                          {"evaluation",
                           {{"all_pass", verdict == "pass"},
                            {"products",
                             {{{"channel", "/p"},
                               {"position_error_m", {{"p95", p95_m}}},
                               {"tracked_fraction", p95_m < 1.0 ? 0.95 : 0.2}}}},
                            {"requirements",
                             {{{"id", "SR"},
                               {"channel", "/p"},
                               {"quantity", "position_error_m"},
                               {"comparison", "<"},
                               {"threshold", 1.0},
                               {"verdict", verdict},
                               {"measured", p95_m}}}}}}};
  };
  // runs 0 and 2: the first entry, evaluated; run 1: the occluded entry, evaluated with faults;
  // run 3: the occluded entry without a pose
  std::vector<nlohmann::json> results = {evaluated(0.1, false),
                                         evaluated(2.0, true),
                                         evaluated(0.3, false),
                                         {{"status", "no_product"}}};
  for (std::uint64_t i = 0; i < results.size(); ++i) {
    results[i]["index"] = i;
    results[i]["reproduce"] = "run " + std::to_string(i);
    results[i]["label"] = c->scenarios[i % 2].label;
    results[i]["scenario"] = c->scenarios[i % 2].name;
    ASSERT_TRUE(writeResult(dir, i, results[i]).isOk());
  }
  // run 0 also has the graph's pose product at mid range: the graph's goals apply to it
  // (dfpcs/lidar_tracking.yaml: beyond 5 m, p95 below 0.5 % of the range and 1 degree)
  results[0]["evaluation"]["products"].push_back({{"channel", "/cdff/lidar_tracking/pose"},
                                                  {"matched_frames", 10},
                                                  {"range_m", {{"min", 15.0}, {"max", 17.0}}},
                                                  {"position_error_pct_range", {{"p95", 0.3}}},
                                                  {"angle_error_deg", {{"p95", 1.5}}}});
  ASSERT_TRUE(writeResult(dir, 0, results[0]).isOk());
  Result<nlohmann::json> report = campaignReport(*c, dir);
  ASSERT_TRUE(report) << report.status().message();
  std::map<std::string, std::pair<int, int>> goals;  // title: pass, fail
  for (const nlohmann::json& row : (*report)["requirements"])
    if (row["id"] == "goal lidar_tracking")
      goals[row["title"]] = {row["pass"].get<int>(), row["fail"].get<int>()};
  ASSERT_EQ(goals.size(), 4u);  // its four goals, two of them in a band no run was in
  EXPECT_EQ(goals["lidar_tracking goal: p95 position_error_pct_range < 0.5 over 5-1000 m"],
            std::make_pair(1, 0));
  EXPECT_EQ(goals["lidar_tracking goal: p95 angle_error_deg < 1 over 5-1000 m"],
            std::make_pair(0, 1));
  EXPECT_EQ(goals["lidar_tracking goal: p95 angle_error_deg < 0.5 over 0-5 m"],
            std::make_pair(0, 0));
  const nlohmann::json& sr = (*report)["requirements"][0];
  EXPECT_EQ(sr["pass"], 2);
  EXPECT_EQ(sr["fail"], 2);  // run 1's 2 m, and run 3 without a pose (its entry had a verdict)
  EXPECT_EQ(sr["failed_without_product"], 1);
  EXPECT_EQ(sr["worst_runs"][0]["index"], 1);
  EXPECT_DOUBLE_EQ(sr["measured"]["min"], 0.1);
  EXPECT_DOUBLE_EQ(sr["measured"]["max"], 2.0);
  const nlohmann::json& scenarios = (*report)["scenarios"];
  ASSERT_EQ(scenarios.size(), 2u);
  EXPECT_EQ(scenarios[0]["label"], "mid_range_approach");
  EXPECT_EQ(scenarios[0]["ok"], 2);
  EXPECT_EQ(scenarios[0]["all_pass"], 2);
  EXPECT_EQ(scenarios[0]["with_dfpc_faults"], 0);
  EXPECT_DOUBLE_EQ(scenarios[0]["products"]["/p"]["position_error_m_p95"]["max"], 0.3);
  EXPECT_EQ(scenarios[1]["label"], "occluded");
  EXPECT_EQ(scenarios[1]["ok"], 1);
  EXPECT_EQ(scenarios[1]["no_product"], 1);
  EXPECT_EQ(scenarios[1]["all_pass"], 0);
  EXPECT_EQ(scenarios[1]["with_dfpc_faults"], 1);
  // the tracked fraction is a lower bound: its low end is there
  EXPECT_DOUBLE_EQ((*report)["products"]["/p"]["tracked_fraction"]["min"], 0.2);
  EXPECT_NE(reportText(*report).find("scenario occluded: 2 runs, 1 evaluated (0 meeting every "
                                     "requirement that applied), 1 without a pose, 0 failed, 1 "
                                     "with DFPC faults"),
            std::string::npos);
  EXPECT_NE(reportHtml(*report).find("<h2>By scenario</h2>"), std::string::npos);
  // a result edited by hand: an error that names its file, nothing thrown
  results[2]["status"] = 7;
  ASSERT_TRUE(writeResult(dir, 2, results[2]).isOk());
  Result<nlohmann::json> edited = campaignReport(*c, dir);
  ASSERT_FALSE(edited);
  EXPECT_NE(edited.status().message().find("runs/000002/result.json' is not a run result"),
            std::string::npos)
      << edited.status().message();
  std::ofstream(resultFile(dir, 2)) << "[1, 2]";
  EXPECT_NE(campaignReport(*c, dir).status().message().find("is not a run result (a JSON object)"),
            std::string::npos);
  fs::remove_all(dir);
}

// A run through several of Table 1's phases (the rendezvous) has each requirement tallied per
// phase too; a run within one phase has no phase rows. Each product's NEES and largest step are
// distributed over the runs, and the text report gives them.
TEST(Report, TalliesEachPhaseAndTheProductsConsistencyAndSteps) {
  Result<Campaign> c = parseCampaign(faultEntries(), "f.yaml");
  ASSERT_TRUE(c) << c.status().message();
  const fs::path dir = fs::temp_directory_path() / "cdff_campaign_phase_test";
  fs::remove_all(dir);
  ASSERT_TRUE(prepareResults(*c, dir).isOk());
  const auto verdict = [](double measured) {
    return nlohmann::json{
        {"id", "SR_DFPC_0100"}, {"channel", "/s"},  {"quantity", "position_error_m"},
        {"comparison", "<"},    {"threshold", 1.0}, {"verdict", measured < 1.0 ? "pass" : "fail"},
        {"measured", measured}};
  };
  const auto run = [&](double far_m, double mid_m, double nees, double step, bool two_phases) {
    nlohmann::json phases = {{{"name", "far range"}, {"verdicts", {verdict(far_m)}}}};
    if (two_phases) phases.push_back({{"name", "mid range"}, {"verdicts", {verdict(mid_m)}}});
    return nlohmann::json{{"status", "ok"},
                          {"label", c->scenarios[0].label},
                          {"scenario", c->scenarios[0].name},
                          {"evaluation",
                           {{"requirements", {verdict(std::max(far_m, mid_m))}},
                            {"phases", phases},
                            {"products",
                             {{{"channel", "/s"},
                               {"covariance_consistency", {{"position_nees_mean", nees}}},
                               {"continuity", {{"max_step_sigma", step}}}}}}}}};
  };
  ASSERT_TRUE(writeResult(dir, 0, run(1.5, 0.5, 3.0, 1.0, true)).isOk());
  ASSERT_TRUE(writeResult(dir, 1, run(0.8, 0.4, 9.0, 5.0, true)).isOk());
  ASSERT_TRUE(writeResult(dir, 2, run(0.2, 0.2, 6.0, 2.0, false)).isOk());
  Result<nlohmann::json> report = campaignReport(*c, dir);
  ASSERT_TRUE(report) << report.status().message();
  std::map<std::string, std::pair<int, int>> rows;  // id: pass, fail
  for (const nlohmann::json& row : (*report)["requirements"])
    rows[row["id"]] = {row["pass"].get<int>(), row["fail"].get<int>()};
  EXPECT_EQ(rows["SR_DFPC_0100"], std::make_pair(2, 1));
  EXPECT_EQ(rows["SR_DFPC_0100 in far range"], std::make_pair(1, 1));  // run 2: one phase
  EXPECT_EQ(rows["SR_DFPC_0100 in mid range"], std::make_pair(2, 0));
  const nlohmann::json& s = (*report)["products"]["/s"];
  EXPECT_DOUBLE_EQ(s["position_nees_mean"]["p50"], 6.0);
  EXPECT_DOUBLE_EQ(s["max_step_sigma"]["max"], 5.0);
  EXPECT_NE(reportText(*report).find("/s: position_nees_mean p50 6 max 9; max_step_sigma p50 2 "
                                     "max 5;"),
            std::string::npos)
      << reportText(*report);
  fs::remove_all(dir);
}

TEST(Pool, ARunWhoseProcessCrashesIsRetriedOnceThenRecorded) {
  Result<Campaign> c = parseCampaign(campaignText(), "crash.yaml");
  ASSERT_TRUE(c);
  c->runs = 2;
  const fs::path dir = fs::temp_directory_path() / "cdff_campaign_pool_test";
  fs::remove_all(dir);
  ASSERT_TRUE(prepareResults(*c, dir).isOk());
  PoolOptions options;
  options.jobs = 2;
  options.progress = false;
  // A run process that kills itself and counts its attempts in the run's folder.
  options.run_command = {"/bin/sh", "-c", "echo x >> \"$0/runs/00000$1/attempts\"; kill -SEGV $$",
                         dir.string()};
  Result<PoolSummary> s = runPool(*c, dir, options);
  ASSERT_TRUE(s) << s.status().message();
  EXPECT_EQ(s->completed, 2u);
  EXPECT_EQ(s->failed, 2u);
  EXPECT_EQ(s->retried, 2u);
  for (int i = 0; i < 2; ++i) {
    std::ifstream attempts(runDirectory(dir, i) / "attempts");
    std::string line;
    int n = 0;
    while (std::getline(attempts, line)) ++n;
    EXPECT_EQ(n, 2);  // once, then retried once
    const nlohmann::json r = nlohmann::json::parse(std::ifstream(resultFile(dir, i)));
    EXPECT_EQ(r["status"], "failed");
    EXPECT_NE(r["error"].get<std::string>().find("killed by signal 11"), std::string::npos);
    EXPECT_NE(r["reproduce"].get<std::string>().find("--seed"), std::string::npos);
  }
  // a second call finds every run done and does nothing
  Result<PoolSummary> again = runPool(*c, dir, options);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->skipped, 2u);
  EXPECT_EQ(again->completed, 0u);
  fs::remove_all(dir);
}

TEST(Pool, ProcessesOfOneClaimGroupShareTheRunsAndDoEachOnce) {
  Result<Campaign> c = parseCampaign(campaignText(), "claims.yaml");
  ASSERT_TRUE(c);
  c->runs = 8;
  const fs::path dir = fs::temp_directory_path() / "cdff_campaign_claim_test";
  fs::remove_all(dir);
  ASSERT_TRUE(prepareResults(*c, dir).isOk());
  // A run process that notes that it ran, takes a moment, and writes its result.
  auto options = [&](std::uint64_t slice) {
    PoolOptions o;
    o.jobs = 1;
    o.progress = false;
    o.claim_group = "job7";
    o.slice_index = slice;
    o.slice_count = 2;
    o.run_command = {"/bin/sh", "-c",
                     "d=\"$0/runs/00000$1\"; echo $$ >> \"$d/ran\"; sleep 0.1; "
                     "echo '{\"status\": \"ok\"}' > \"$d/result.json\"",
                     dir.string()};
    return o;
  };
  Result<PoolSummary> a = Status::ok(), b = Status::ok();
  std::thread other([&] { b = runPool(*c, dir, options(1)); });
  a = runPool(*c, dir, options(0));
  other.join();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->completed + b->completed, 8u);
  EXPECT_GT(a->completed, 0u);
  EXPECT_GT(b->completed, 0u);
  for (int i = 0; i < 8; ++i) {
    std::ifstream ran(runDirectory(dir, i) / "ran");
    std::string line;
    int n = 0;
    while (std::getline(ran, line)) ++n;
    EXPECT_EQ(n, 1) << "run " << i;
  }
  // a later group (a resubmitted job) ignores the claims of this one: nothing is left to do
  PoolOptions later = options(0);
  later.claim_group = "job8";
  Result<PoolSummary> again = runPool(*c, dir, later);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->skipped, 8u);
  fs::remove_all(dir);
}

TEST(Pool, AFolderOfAnotherCampaignIsRefused) {
  Result<Campaign> a = parseCampaign(campaignText(), "a.yaml");
  Result<Campaign> b = parseCampaign(campaignText() + "# another\n", "b.yaml");
  ASSERT_TRUE(a && b);
  const fs::path dir = fs::temp_directory_path() / "cdff_campaign_identity_test";
  fs::remove_all(dir);
  ASSERT_TRUE(prepareResults(*a, dir).isOk());
  EXPECT_TRUE(prepareResults(*a, dir).isOk());  // the same campaign resumes
  const Status refused = prepareResults(*b, dir);
  EXPECT_EQ(refused.code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.message().find("holds the results of campaign 't' (a.yaml)"), std::string::npos)
      << refused.message();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cdff::campaign
