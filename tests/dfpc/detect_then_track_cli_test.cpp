// Detect, then track, with no ground truth, end to end through the command line.
//
// Stereo, then visual tracking: `cdff sim
// close_range_approach` records both cameras at 5 Hz; `cdff run` runs the detection DFPC on the
// stereo pairs made from the two cameras' channels (--pair) while the visual tracking DFPC is
// UNINITIALISED or LOST (--run-while), the detection's camera-frame state is the tracker's
// initial pose (--map); `cdff eval` pairs the tracker's pose with the simulator's truth. The
// templates are the CTest fixture's coarse set (tests/dfpc/CMakeLists.txt). The first 10 s of
// the approach (3.2 m to 2.9 m between the centres of mass) keep the run affordable in CI.
//
// ToF, then LIDAR tracking: `cdff sim mid_range_approach` records the ToF camera (10 Hz) and the
// VLP-16; `cdff run` runs the ToF detection DFPC while the LIDAR tracking DFPC is UNINITIALISED
// or LOST, and the detection's servicer-frame state is the tracker's initial state. The
// templates are the ToF fixture's coarse set. The window 50-62 s of the approach (7.5 m to
// 4.5 m) holds depth maps whose best pose is withheld (a half turn fits nearly as well) before
// the first one that is trusted: the mounting, delivered once at the start of the window, must
// still be there.
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
using cdff::testing::firstTracking;
using cdff::testing::readReport;
using cdff::testing::reportProduct;
using cdff::testing::runCdff;
using cdff::testing::scratchDirectory;

TEST(DetectThenTrackCommandLine, TheDetectionStartsTheVisualTrackerAndStopsWhileItTracks) {
  const fs::path dir = scratchDirectory("cdff_detect_track");
  // The graphs' model files are relative to the repository root.
  fs::current_path(CDFF_SOURCE_DIR);
  const std::string sim = (dir / "sim.mcap").string(), out = (dir / "out.mcap").string(),
                    json = (dir / "report.json").string();
  CommandResult r = runCdff(fmt::format(
      "sim close_range_approach -o {} -q --duration 10 --set sensors.camera_left.rate=5 "
      "--set sensors.camera_right.rate=5 --set sensors.lidar.enabled=false "
      "--set sensors.tof.enabled=false --set sensors.imu.enabled=false",
      sim));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runCdff(
      fmt::format("run dfpcs/detection.yaml dfpcs/visual_tracking.yaml -i {} -o {} -q "
                  "--set detect.template_file={} "
                  "--pair /chaser/stereo/pair=/chaser/camera/left/image,/chaser/camera/right/image "
                  "--map visual_tracking.initial_pose=/cdff/detection/camera_state "
                  "--run-while detection=visual_tracking:UNINITIALISED,LOST",
                  sim, out, CDFF_DETECTION_TEMPLATES));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  // The detection ran on the pairs until the tracker tracked, then stopped (the first pair
  // today: 2 messages, the pair and the mounting).
  std::smatch m;
  const std::regex detection_line(R"(detection: stopped, (\d+) messages)");
  ASSERT_TRUE(std::regex_search(r.output, m, detection_line)) << r.output;
  EXPECT_LE(std::stoi(m[1]), 20);

  // The issue's goal: TRACKING within 2 s of the first frame.
  const double tracking = firstTracking(out, "visual_tracking");
  std::printf("first TRACKING at %.1f s\n", tracking);
  EXPECT_GE(tracking, 0) << "the tracker never tracked";
  EXPECT_LE(tracking, 2.0);

  r = runCdff(fmt::format("eval {} --json {} --product /cdff/visual_tracking/pose", out, json));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  const nlohmann::json report = readReport(json);
  const nlohmann::json* pose = reportProduct(report, "/cdff/visual_tracking/pose");
  ASSERT_NE(pose, nullptr) << report.dump(2);
  // Tracked from the hand-over on (the issue: >= 98 % of the frames), and the accuracy the
  // visual tracker meets from a perturbed truth at close range: p95 <= 10 mm and 0.5 degrees.
  EXPECT_GE(pose->at("tracked_fraction").get<double>(), 0.98);
  EXPECT_GE(pose->at("valid_frames").get<int>(), 30);
  EXPECT_LE(pose->at("position_error_m").at("p95").get<double>(), 0.010);
  EXPECT_LE(pose->at("angle_error_deg").at("p95").get<double>(), 0.5);
  if (!HasFailure()) fs::remove_all(dir);  // else kept for a look (cdff log, cdff eval)
}

TEST(DetectThenTrackTofCommandLine, TheToFDetectionStartsTheLidarTracker) {
  const fs::path dir = scratchDirectory("cdff_detect_track_tof");
  // The graphs' model files are relative to the repository root.
  fs::current_path(CDFF_SOURCE_DIR);
  const std::string sim = (dir / "sim.mcap").string(), out = (dir / "out.mcap").string(),
                    json = (dir / "report.json").string();
  CommandResult r = runCdff(fmt::format(
      "sim mid_range_approach -o {} -q --duration 62 --set sensors.camera_left.enabled=false "
      "--set sensors.camera_right.enabled=false --set sensors.imu.enabled=false",
      sim));
  ASSERT_EQ(r.status, 0) << r.output;
  r = runCdff(fmt::format(
      "run dfpcs/detection_tof.yaml dfpcs/lidar_tracking.yaml -i {} -o {} -q --start 50 "
      "--set detect.template_file={} "
      "--map lidar_tracking.initial_state=/cdff/detection_tof/pose "
      "--run-while detection_tof=lidar_tracking:UNINITIALISED,LOST",
      sim, out, CDFF_DETECTION_TOF_TEMPLATES));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  // The detection ran without a fault until the tracker took its pose, then stopped.
  std::smatch m;
  const std::regex detection_line(
      R"(detection_tof: stopped, (\d+) messages, \d+ products, (\d+) faults)");
  ASSERT_TRUE(std::regex_search(r.output, m, detection_line)) << r.output;
  EXPECT_EQ(std::stoi(m[2]), 0);

  // Today (2026-12-05) the first trusted detection comes at 57.6 s (5.8 m); the bound guards it.
  const double tracking = firstTracking(out, "lidar_tracking");
  std::printf("first TRACKING at %.1f s\n", tracking);
  EXPECT_GE(tracking, 50.0) << "the tracker never tracked";
  EXPECT_LE(tracking, 60.0);

  r =
      runCdff(fmt::format("eval {} --json {} --product /cdff/lidar_tracking/pose "
                          "--product /cdff/detection_tof/pose",
                          out, json));
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s\n", r.output.c_str());
  const nlohmann::json report = readReport(json);
  // Every published detection is right: within 1 % of the range and 2 degrees (the goal after
  // refinement); a withheld one publishes nothing.
  const nlohmann::json* detection = reportProduct(report, "/cdff/detection_tof/pose");
  ASSERT_NE(detection, nullptr) << report.dump(2);
  EXPECT_LE(detection->at("position_error_pct_range").at("max").get<double>(), 1.0);
  EXPECT_LE(detection->at("angle_error_deg").at("max").get<double>(), 2.0);
  // Tracked from the hand-over on (the issue: >= 98 % of the frames), with the accuracy the
  // LIDAR tracker's mid-range goal asks from a perturbed truth: p95 0.5 % of the range and 1
  // degree (today 0.26 % and 0.41 degrees, the hand-over's first second included).
  const nlohmann::json* pose = reportProduct(report, "/cdff/lidar_tracking/pose");
  ASSERT_NE(pose, nullptr) << report.dump(2);
  EXPECT_GE(pose->at("tracked_fraction").get<double>(), 0.98);
  EXPECT_GE(pose->at("valid_frames").get<int>(), 50);
  EXPECT_LE(pose->at("position_error_pct_range").at("p95").get<double>(), 0.5);
  EXPECT_LE(pose->at("angle_error_deg").at("p95").get<double>(), 1.0);
  if (!HasFailure()) fs::remove_all(dir);  // else kept for a look (cdff log, cdff eval)
}

}  // namespace
