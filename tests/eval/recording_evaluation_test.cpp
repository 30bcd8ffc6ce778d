// `cdff eval` on recordings whose errors, track losses and latencies are known by construction:
// the pairing of products with truth, validity from track-state events, latency from timing
// records, the reports and the command's statuses.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/io/recorder.hpp"
#include "support/command.hpp"

namespace cdff::eval {
namespace {

namespace fs = std::filesystem;
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kOffsetM = 0.02;     // the product's position error
constexpr double kOffsetDeg = 0.5;    // its attitude error
constexpr double kStepWallS = 0.004;  // two DFN calls of 2 ms per step

#define ASSERT_OK_STATUS(expr)                               \
  do {                                                       \
    const ::cdff::Status s_ = (expr);                        \
    ASSERT_TRUE(s_.isOk()) << #expr << ": " << s_.message(); \
  } while (0)

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "cdff_recording_evaluation_test";
  fs::create_directories(dir);
  return dir / name;
}

Transform truthPose(double t) {
  Transform pose = Transform::identity("servicer", "target", fromSeconds(t));
  pose.translation = {0.5, 0.0, 17.0 - 0.5 * t};  // 17 m -> 2 m in 30 s
  pose.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(t * kDegToRad, Eigen::Vector3d::UnitY()));
  return pose;
}

// Truth at 20 Hz; a tracker product at 10 Hz with a fixed error; the tracker LOST from 10 s to
// 12 s (its products there are off by 5 m and must not count); two timing records per step; a
// second product of another transform (no truth for it).
void writeRun(const fs::path& path) {
  io::Recorder rec;
  ASSERT_OK_STATUS(rec.open(path.string()));
  for (int k = 0; k <= 600; ++k) {
    const double t = 0.05 * k;
    ASSERT_OK_STATUS(rec.write("/truth/target_pose", PoseWithCovariance{truthPose(t), {}}));
  }
  ASSERT_OK_STATUS(rec.writeJson("/cdff/events", 0,
                                 {{"level", "info"},
                                  {"type", "track_state_changed"},
                                  {"dfpc", "trk"},
                                  {"message", "UNINITIALISED -> TRACKING"}}));
  for (int k = 0; k <= 300; ++k) {
    const double t = 0.1 * k;
    const Timestamp stamp = fromSeconds(t);
    if (k == 200)  // another DFPC started by a rule (a hand-over)
      ASSERT_OK_STATUS(rec.writeJson(
          "/cdff/events", stamp,
          {{"level", "info"}, {"type", "activated"}, {"dfpc", "other"}, {"instance", ""}}));
    if (k == 100 || k == 121)
      ASSERT_OK_STATUS(
          rec.writeJson("/cdff/events", stamp,
                        {{"level", "info"},
                         {"type", "track_state_changed"},
                         {"dfpc", "trk"},
                         {"message", k == 100 ? "TRACKING -> LOST" : "LOST -> TRACKING"}}));
    RigidBodyState x;
    x.pose = truthPose(t);
    x.pose.translation.x() += k >= 100 && k < 121 ? 5.0 : kOffsetM;
    x.pose.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(kOffsetDeg * kDegToRad, Eigen::Vector3d::UnitX())) *
        x.pose.rotation;
    // Sigmas of 1 cm and kOffsetDeg: the constructed errors' NEES is (2 cm / 1 cm)^2 + 1 = 5.
    x.covariance = Matrix12d::Identity() * 1e-2;
    x.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-4;
    x.covariance.block<3, 3>(3, 3) =
        Eigen::Matrix3d::Identity() * std::pow(kOffsetDeg * kDegToRad, 2);
    ASSERT_OK_STATUS(rec.write("/cdff/trk/pose", x));
    for (const char* dfn : {"icp", "ekf"})
      ASSERT_OK_STATUS(rec.writeJson("/cdff/trk/timing", stamp,
                                     {{"dfn", dfn}, {"wall_s", kStepWallS / 2}, {"cpu_s", 0.0}}));
    Transform other = Transform::identity("camera", "marker", stamp);
    ASSERT_OK_STATUS(rec.write("/cdff/trk/marker", other));
  }
  ASSERT_OK_STATUS(rec.close());
}

TEST(RecordingEvaluation, PairsByFramesAndUsesTrackStateAndTiming) {
  const fs::path run = scratch("run.mcap");
  writeRun(run);
  RecordingEvaluationNotes notes;
  Result<EvaluationReport> report = evaluateRecording({run.string()}, {}, &notes);
  ASSERT_TRUE(report.isOk()) << report.status().message();
  ASSERT_EQ(report->products.size(), 1u);
  const PoseEvaluation& p = report->products[0];
  EXPECT_EQ(p.channel, "/cdff/trk/pose");
  EXPECT_EQ(p.truth_channel, "/truth/target_pose");
  EXPECT_EQ(p.frames, 301u);
  EXPECT_EQ(p.valid_frames, 280u);  // 21 products while LOST
  EXPECT_NEAR(p.tracked_fraction, 280.0 / 301.0, 1e-12);
  EXPECT_NEAR(p.position_error_m.max, kOffsetM, 1e-9);  // the 5 m errors while LOST excluded
  EXPECT_NEAR(p.position_error_m.rmse, kOffsetM, 1e-9);
  EXPECT_NEAR(p.angle_error_deg.max, kOffsetDeg, 1e-6);
  // The pose block of the states' covariance, read back from the recording (the truth's
  // all-zero covariance is none).
  EXPECT_EQ(p.covariance.count, 280u);
  EXPECT_NEAR(p.covariance.nees_mean, 5.0, 1e-6);
  EXPECT_NEAR(p.covariance.position_nees_mean, 4.0, 1e-6);
  EXPECT_NEAR(p.covariance.attitude_nees_mean, 1.0, 1e-6);
  ASSERT_EQ(p.latency_s.count, 280u);
  EXPECT_NEAR(p.latency_s.max, kStepWallS, 1e-12);
  // The worst interval between valid products is the 2.1 s loss.
  EXPECT_NEAR(p.min_rate_hz, 1.0 / 2.2, 1e-6);
  // The marker product has no truth of its transform: noted, not evaluated.
  ASSERT_EQ(notes.notes.size(), 1u);
  EXPECT_NE(notes.notes[0].find("/cdff/trk/marker"), std::string::npos);
  EXPECT_NE(notes.notes[0].find("camera_T_marker"), std::string::npos);
  // Mid-range and close-range verdicts: 0.02 m and 0.5 deg pass both.
  int passes = 0;
  for (const RequirementVerdict& v : report->requirements) passes += v.verdict == Verdict::kPass;
  EXPECT_EQ(passes, 3);  // mid range position, angle, and the rate (no estimate under 2 m)
  EXPECT_TRUE(report->allPass());
}

// The phases of the run (seed Table 1, by the true range): 17 m -> 2 m in 30 s is mid range
// until the range falls below 5 m (24.05 s), then close range; each phase has its own verdicts
// over the estimates made during it, the update rate counting the phase's ends.
TEST(RecordingEvaluation, GivesEachPhaseItsOwnVerdicts) {
  const fs::path run = scratch("phases.mcap");
  writeRun(run);
  Result<EvaluationReport> report = evaluateRecording({run.string()});
  ASSERT_TRUE(report.isOk()) << report.status().message();
  ASSERT_EQ(report->phases.size(), 2u);
  const PhaseResult& mid = report->phases[0];
  const PhaseResult& close = report->phases[1];
  EXPECT_EQ(mid.span.phase.name, "mid range");
  EXPECT_EQ(close.span.phase.name, "close range");
  EXPECT_EQ(mid.span.start, 0);
  EXPECT_EQ(mid.span.end, fromSeconds(24.05));
  EXPECT_EQ(close.span.start, fromSeconds(24.1));
  EXPECT_EQ(close.span.end, fromSeconds(30.0));
  const auto verdict = [](const PhaseResult& phase, const std::string& id,
                          const std::string& quantity) -> const RequirementVerdict* {
    for (const RequirementVerdict& v : phase.verdicts)
      if (v.id == id && v.quantity == quantity && v.channel == "/cdff/trk/pose") return &v;
    return nullptr;
  };
  // Mid range: the loss from 10 s to 12.1 s is its longest gap.
  const RequirementVerdict* mid_rate = verdict(mid, "SR_DFPC_0102", "update_rate_hz");
  ASSERT_NE(mid_rate, nullptr);
  EXPECT_NEAR(mid_rate->measured, 1.0 / 2.2, 1e-6);
  const RequirementVerdict* mid_position = verdict(mid, "SR_DFPC_0100", "position_error_m");
  ASSERT_NE(mid_position, nullptr);
  EXPECT_EQ(mid_position->verdict, Verdict::kPass);
  EXPECT_EQ(mid_position->frames, 220u);  // 0-24 s at 10 Hz, the 21 lost ones out
  EXPECT_NEAR(mid_position->measured, kOffsetM, 1e-9);
  // Close range: products every 0.1 s from the phase's start; nothing under 2 m (SR_DFPC_0101
  // does not apply and is left out).
  const RequirementVerdict* close_rate = verdict(close, "SR_DFPC_0102", "update_rate_hz");
  ASSERT_NE(close_rate, nullptr);
  EXPECT_NEAR(close_rate->measured, 10.0, 1e-6);
  EXPECT_EQ(verdict(close, "SR_DFPC_0101", "position_error_m"), nullptr);
  ASSERT_NE(verdict(close, "SR_DFPC_0100", "angle_error_deg"), nullptr);
  EXPECT_EQ(verdict(close, "SR_DFPC_0100", "angle_error_deg")->frames, 60u);  // 24.1-30 s

  // The hand-over at 20 s, and the product's steps after it: it moves 5 cm between estimates
  // while its twist says it stands still, 5 sigma of its 1 cm position sigma.
  ASSERT_EQ(report->handovers.size(), 1u);
  EXPECT_EQ(report->handovers[0].stamp, fromSeconds(20));
  EXPECT_EQ(report->handovers[0].dfpc, "other");
  ASSERT_EQ(report->handovers[0].max_step_sigma.size(), 1u);
  EXPECT_EQ(report->handovers[0].max_step_sigma[0].first, "/cdff/trk/pose");
  EXPECT_NEAR(report->handovers[0].max_step_sigma[0].second, 5.0, 0.01);
  EXPECT_EQ(report->products[0].continuity.jumps, report->products[0].continuity.steps.size());

  const nlohmann::json json = toJson(*report);
  ASSERT_EQ(json.at("phases").size(), 2u);
  EXPECT_EQ(json.at("handovers").size(), 1u);
  EXPECT_EQ(json["phases"][1]["name"], "close range");
  EXPECT_NEAR(json["phases"][1]["start_s"].get<double>(), 24.1, 1e-9);
  EXPECT_NE(toText(*report).find("close range  (0-5 m; 24.1-30.0 s)"), std::string::npos)
      << toText(*report);
  // The plots share the run's time axis and mark each phase's start.
  const std::string html = toHtml(*report);
  EXPECT_NE(html.find("time since the run's start [s]"), std::string::npos);
  EXPECT_NE(html.find("class='marker'"), std::string::npos);
}

TEST(Phases, SpansFollowTheTrueRangeAndGapsCountThePhasesEnds) {
  std::vector<Transform> truth;
  for (int k = 0; k <= 200; ++k) {  // 200 m -> 0 m, one sample a second
    Transform t = Transform::identity("servicer", "target", fromSeconds(k));
    t.translation = {0, 0, 200.0 - k};
    truth.push_back(t);
  }
  const std::vector<PhaseSpan> spans = phaseSpans(truth);
  ASSERT_EQ(spans.size(), 3u);
  EXPECT_EQ(spans[0].phase.name, "far range");
  EXPECT_EQ(spans[0].end, fromSeconds(100));  // 100 m: far range's band starts there
  EXPECT_EQ(spans[1].start, fromSeconds(101));
  EXPECT_EQ(spans[1].end, fromSeconds(195));  // 5 m belongs to mid range
  EXPECT_EQ(spans[2].start, fromSeconds(196));
  EXPECT_TRUE(phaseSpans({}).empty());
  // A product from 20 s to 90 s, every 10 s, in a phase from 0 to 100 s: the 20 s before it
  // is the longest gap; with nothing in the phase, the whole phase is.
  std::vector<Timestamp> stamps;
  for (int s = 20; s <= 90; s += 10) stamps.push_back(fromSeconds(s));
  EXPECT_DOUBLE_EQ(longestGapWithin(stamps, 0, fromSeconds(100)), 20.0);
  EXPECT_DOUBLE_EQ(longestGapWithin(stamps, fromSeconds(20), fromSeconds(130)), 40.0);
  EXPECT_DOUBLE_EQ(longestGapWithin({}, 0, fromSeconds(100)), 100.0);
}

// A DFPC publishes its external initial state before the track is acquired: the products stamped
// before the first track-state change take the state that change leaves (UNINITIALISED here);
// neither those nor the products while ACQUIRING, 1 m off, count as tracked frames.
TEST(RecordingEvaluation, NothingCountsAsTrackedBeforeTheTrackIsAcquired) {
  const fs::path run = scratch("run_initial_state.mcap");
  {
    io::Recorder rec;
    ASSERT_OK_STATUS(rec.open(run.string()));
    for (int k = 0; k <= 100; ++k)
      ASSERT_OK_STATUS(
          rec.write("/truth/target_pose", PoseWithCovariance{truthPose(0.05 * k), {}}));
    for (int k = 0; k <= 50; ++k) {
      const double t = 0.1 * k;
      if (k == 3 || k == 5)
        ASSERT_OK_STATUS(rec.writeJson(
            "/cdff/events", fromSeconds(t),
            {{"level", "info"},
             {"type", "track_state_changed"},
             {"dfpc", "trk"},
             {"message", k == 3 ? "UNINITIALISED -> ACQUIRING" : "ACQUIRING -> TRACKING"}}));
      RigidBodyState x;
      x.pose = truthPose(t);
      x.pose.translation.x() += k < 5 ? 1.0 : kOffsetM;
      ASSERT_OK_STATUS(rec.write("/cdff/trk/pose", x));
    }
    ASSERT_OK_STATUS(rec.close());
  }
  Result<EvaluationReport> report = evaluateRecording({run.string()});
  ASSERT_TRUE(report.isOk()) << report.status().message();
  ASSERT_EQ(report->products.size(), 1u);
  const PoseEvaluation& p = report->products[0];
  EXPECT_EQ(p.frames, 51u);
  EXPECT_EQ(p.valid_frames, 46u);  // the five products before the track was acquired excluded
  EXPECT_NEAR(p.position_error_m.max, kOffsetM, 1e-9);
}

TEST(RecordingEvaluation, SaysWhatIsMissing) {
  const fs::path run = scratch("run_missing.mcap");
  writeRun(run);
  RecordingEvaluationOptions only;
  only.products = {"/cdff/trk/nothing"};
  Result<EvaluationReport> r = evaluateRecording({run.string()}, only);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("/cdff/trk/nothing"), std::string::npos);
  EXPECT_NE(r.status().message().find("/cdff/trk/pose"), std::string::npos);  // the choices

  RecordingEvaluationOptions pair;
  pair.pairs["/cdff/trk/pose"] = "/truth/nothing";
  r = evaluateRecording({run.string()}, pair);
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("/truth/target_pose"), std::string::npos);

  // No truth at all.
  const fs::path no_truth = scratch("no_truth.mcap");
  {
    io::Recorder rec;
    ASSERT_OK_STATUS(rec.open(no_truth.string()));
    ASSERT_OK_STATUS(rec.write("/cdff/trk/pose", RigidBodyState{}));
    ASSERT_OK_STATUS(rec.close());
  }
  r = evaluateRecording({no_truth.string()});
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("no ground truth"), std::string::npos);

  r = evaluateRecording({scratch("absent.mcap").string()});
  ASSERT_FALSE(r.isOk());
  EXPECT_NE(r.status().message().find("absent.mcap"), std::string::npos);
}

using cdff::testing::CommandResult;
using cdff::testing::runCdff;

TEST(EvalCommand, WritesTheDocumentedReports) {
  const fs::path run = scratch("cmd_run.mcap"), json = scratch("report.json"),
                 html = scratch("report.html");
  writeRun(run);
  const CommandResult r = runCdff(
      fmt::format("eval {} --json {} --html {}", run.string(), json.string(), html.string()));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("/cdff/trk/pose"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("SR_DFPC_0100"), std::string::npos) << r.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  ASSERT_EQ(j["products"].size(), 1u);
  const nlohmann::json& p = j["products"][0];
  EXPECT_EQ(p["channel"], "/cdff/trk/pose");
  EXPECT_NEAR(p["position_error_m"]["p95"].get<double>(), kOffsetM, 1e-9);
  EXPECT_NEAR(p["position_error_pct_range"]["max"].get<double>(), 100 * kOffsetM / 2.0, 0.1);
  EXPECT_NEAR(p["angle_error_deg"]["rmse"].get<double>(), kOffsetDeg, 1e-6);
  EXPECT_NEAR(p["tracked_fraction"].get<double>(), 280.0 / 301.0, 1e-9);
  EXPECT_NEAR(p["rate_hz"].get<double>(), 280.0 / 30.0, 0.5);
  for (const nlohmann::json& v : j["requirements"])
    for (const char* key : {"id", "verdict", "measured", "threshold"})
      EXPECT_TRUE(v.contains(key)) << v.dump();
  std::ifstream page(html);
  const std::string text((std::istreambuf_iterator<char>(page)), {});
  EXPECT_NE(text.find("<svg"), std::string::npos);
  // It opens offline: nothing is loaded from elsewhere.
  for (const char* remote : {"src=\"http", "href=\"http", "url(http", "<script"})
    EXPECT_EQ(text.find(remote), std::string::npos) << remote;
}

TEST(EvalCommand, VerdictsGateWithCheckAndBadInputFails) {
  const fs::path run = scratch("cmd_check.mcap");
  writeRun(run);
  // Strict: --statistic max includes nothing larger than 0.02 m: still passes.
  EXPECT_EQ(runCdff(fmt::format("eval {} --statistic max --check -q", run.string())).status, 0);
  const CommandResult bad_stat = runCdff(fmt::format("eval {} --statistic median", run.string()));
  EXPECT_EQ(bad_stat.status, 2);
  EXPECT_NE(bad_stat.output.find("median"), std::string::npos);
  const CommandResult bad_pair = runCdff(fmt::format("eval {} --pair nonsense", run.string()));
  EXPECT_EQ(bad_pair.status, 2);
  const std::string absent = scratch("absent.mcap").string();
  const CommandResult missing = runCdff("eval " + absent);
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.output.find(absent), std::string::npos) << missing.output;
  const CommandResult unwritable =
      runCdff(fmt::format("eval {} --json /nonexistent/dir/r.json", run.string()));
  EXPECT_EQ(unwritable.status, 1);
  EXPECT_NE(unwritable.output.find("/nonexistent/dir/r.json"), std::string::npos);
}

}  // namespace
}  // namespace cdff::eval
