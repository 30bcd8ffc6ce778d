// The rendezvous from 2 km to capture through the command line, as `make demo` runs it: `cdff sim
// rendezvous` (the sensors the run set reads; the left camera at 2 Hz), `cdff run
// dfpcs/rendezvous.yaml` (far-range tracking, the LIDAR's position of the target, LIDAR and
// visual tracking handing the target over by range and track state; no ground truth, no initial
// state) and `cdff eval` per phase. One draw (seed
// 1): a regression guard of the chain and its hand-overs, with bounds near today's figures where
// the goals are not met yet (docs/rendezvous.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <regex>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "support/command.hpp"
#include "support/eval_report.hpp"

namespace {

namespace fs = std::filesystem;
using cdff::testing::CommandResult;
using cdff::testing::readReport;
using cdff::testing::runCdff;
using cdff::testing::scratchDirectory;

// The verdict of `id`/`quantity` for `channel` in the phase named `phase` (null when absent).
const nlohmann::json* phaseVerdict(const nlohmann::json& report, const std::string& phase,
                                   const std::string& channel, const std::string& id,
                                   const std::string& quantity) {
  for (const nlohmann::json& p : report.at("phases"))
    if (p.at("name") == phase)
      for (const nlohmann::json& v : p.at("verdicts"))
        if (v.at("channel") == channel && v.at("id") == id && v.at("quantity") == quantity)
          return &v;
  return nullptr;
}

TEST(RendezvousCommandLine, HandsTheTargetOverFromFarRangeToCapture) {
  const fs::path dir = scratchDirectory("cdff_rendezvous");
  fs::current_path(CDFF_SOURCE_DIR);  // the graphs' model files are relative to the repository
  const std::string sim = (dir / "sim.mcap").string(), out = (dir / "out.mcap").string(),
                    json = (dir / "report.json").string();
  CommandResult r =
      runCdff(fmt::format("sim rendezvous -o {} -q --set sensors.camera_right.enabled=false "
                          "--set sensors.tof.enabled=false --set sensors.camera_left.rate=2",
                          sim));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runCdff(fmt::format("run dfpcs/rendezvous.yaml -i {} -o {} -q", sim, out));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  r = runCdff(fmt::format(
      "eval {} --camera /chaser/camera/far/calibration --product /cdff/far_range_tracking/bearing "
      "--product /cdff/target_state/state --product /cdff/lidar_position/state --json {}",
      out, json));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  const nlohmann::json report = readReport(json);

  // The hand-overs happened by the rules: far_to_target ran from the far range's first track
  // until lidar_position had the target in the scans (today 334.6 s, 40 m, before the far
  // camera stops at 40 m), the far range and lidar_position stopped when the LIDAR tracker found
  // the target (today 427 s, 12 m), the visual tracker started inside 5 m (today 455 s).
  double far_stop = -1, visual_start = -1, far_state_start = -1, far_state_stop = -1;
  for (const nlohmann::json& h : report.at("handovers")) {
    const double t = h.at("t_s").get<double>();
    if (h.at("dfpc") == "far_range_tracking" && h.at("type") == "deactivated" && t > 0)
      far_stop = far_stop < 0 ? t : far_stop;
    if (h.at("dfpc") == "far_to_target" && h.at("type") == "activated")
      far_state_start = far_state_start < 0 ? t : far_state_start;
    if (h.at("dfpc") == "far_to_target" && h.at("type") == "deactivated" && t > 0)
      far_state_stop = t;
    if (h.at("dfpc") == "visual_tracking" && h.at("type") == "activated")
      visual_start = visual_start < 0 ? t : visual_start;
    // The target state never steps beyond 3 sigma within 2 s of a hand-over (the goal;
    // today at most 0.34 sigma in far range, 0.02 sigma from the far range to lidar_position,
    // 2.3 sigma at the visual tracker's start). The LIDAR tracker's acquisition (427 s: 3.1
    // sigma) is not held to it yet.
    if (h.at("max_step_sigma").contains("/cdff/target_state/state") && (t < 400 || t > 440))
      EXPECT_LE(h["max_step_sigma"]["/cdff/target_state/state"].get<double>(), 3.0) << h.dump();
  }
  EXPECT_GE(far_state_start, 0.0);
  EXPECT_LT(far_state_start, 10.0);  // today 2 s
  EXPECT_GT(far_state_stop, 300.0);  // lidar_position from 40-60 m (the far camera stops at 40 m)
  EXPECT_LT(far_state_stop, 340.0);
  EXPECT_GT(far_stop, 400.0);
  EXPECT_LT(far_stop, 440.0);
  EXPECT_GT(visual_start, far_stop);
  EXPECT_LT(visual_start, 470.0);

  // Close range: the target state meets SR_DFPC_0101 (today p95 5.0 mm and 0.22 deg; bounds
  // twice that) and its update rate.
  const std::string state = "/cdff/target_state/state";
  const nlohmann::json* close_position =
      phaseVerdict(report, "close range", state, "SR_DFPC_0101", "position_error_m");
  const nlohmann::json* close_angle =
      phaseVerdict(report, "close range", state, "SR_DFPC_0101", "angle_error_deg");
  const nlohmann::json* close_rate =
      phaseVerdict(report, "close range", state, "SR_DFPC_0102", "update_rate_hz");
  ASSERT_NE(close_position, nullptr) << report.at("phases").dump(2);
  ASSERT_NE(close_angle, nullptr);
  ASSERT_NE(close_rate, nullptr);
  EXPECT_EQ(close_position->at("verdict"), "pass");
  EXPECT_LE(close_position->at("measured").get<double>(), 0.010);
  EXPECT_LE(close_angle->at("measured").get<double>(), 0.5);
  EXPECT_EQ(close_rate->at("verdict"), "pass");
  // Far and mid range: the target state is the far range's estimate down to 40 m (the attitude
  // unobserved: no angle verdict in far range), lidar_position's from 40 m to 12 m (the
  // position only), the LIDAR tracker's from 12 m; position p95 today 1.36 m in far range and
  // 1.07 m in mid range (the far range's part, 100 m to 40 m, dominates); bounds 2 m and 1.5 m.
  // The mid-range attitude fails today (unobserved down to 12 m, then the LIDAR tracker holds
  // the near-symmetric twin for a while). Something measures the target all along: the mid
  // range's update rate passes.
  const nlohmann::json* far_position =
      phaseVerdict(report, "far range", state, "SR_DFPC_0100", "position_error_m");
  ASSERT_NE(far_position, nullptr);
  EXPECT_LE(far_position->at("measured").get<double>(), 2.0);
  EXPECT_EQ(phaseVerdict(report, "far range", state, "SR_DFPC_0100", "angle_error_deg"), nullptr);
  const nlohmann::json* mid_position =
      phaseVerdict(report, "mid range", state, "SR_DFPC_0100", "position_error_m");
  ASSERT_NE(mid_position, nullptr);
  EXPECT_LE(mid_position->at("measured").get<double>(), 1.5);
  const nlohmann::json* mid_rate =
      phaseVerdict(report, "mid range", state, "SR_DFPC_0102", "update_rate_hz");
  ASSERT_NE(mid_rate, nullptr);
  EXPECT_EQ(mid_rate->at("verdict"), "pass");
  // lidar_position, 40 m to 12 m: position p95 today 0.50 m (SR_DFPC_0100: 1 m); bound 0.7 m.
  const std::string scan_position = "/cdff/lidar_position/state";
  const nlohmann::json* scan_mid =
      phaseVerdict(report, "mid range", scan_position, "SR_DFPC_0100", "position_error_m");
  ASSERT_NE(scan_mid, nullptr);
  EXPECT_LE(scan_mid->at("measured").get<double>(), 0.7);
  const nlohmann::json* scan_product = cdff::testing::reportProduct(report, scan_position);
  ASSERT_NE(scan_product, nullptr);
  // Its position covariance: NEES today 3.2 for 3 (one target attitude, whose
  // visible-surface offset is a single draw of what the covariance spreads over all of them).
  EXPECT_LE(scan_product->at("covariance_consistency").at("position_nees_mean").get<double>(), 5.0);
  // Its position covariance is about honest over the run (today NEES 4.0 for 3).
  const nlohmann::json* product = cdff::testing::reportProduct(report, state);
  ASSERT_NE(product, nullptr);
  EXPECT_LE(product->at("covariance_consistency").at("position_nees_mean").get<double>(), 6.0);
  // Far range: the bearing of the centre of mass, today p95 2.8 px (the goal: 0.3 px
  // RMS); bound 4 px; the radar range within 1.5 % (today 1.07 %).
  const std::string bearing = "/cdff/far_range_tracking/bearing";
  const nlohmann::json* far_bearing =
      phaseVerdict(report, "far range", bearing, "UC1_BEARING", "bearing_error_px");
  const nlohmann::json* far_range =
      phaseVerdict(report, "far range", bearing, "UC1_RANGE", "range_error_pct");
  ASSERT_NE(far_bearing, nullptr);
  ASSERT_NE(far_range, nullptr);
  EXPECT_LE(far_bearing->at("measured").get<double>(), 4.0);
  EXPECT_LE(far_range->at("measured").get<double>(), 1.5);
  if (!HasFailure()) fs::remove_all(dir);  // else kept for a look (cdff log, cdff eval)
}

}  // namespace
