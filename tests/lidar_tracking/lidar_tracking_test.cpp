// End to end: dfpcs/lidar_tracking.yaml on the simulator's scenarios (VLP-16 scans with ground
// truth), started from the truth perturbed by 10 % of the range and 10 degrees, against the
// accuracy targets of the LIDAR tracking issue (an order of magnitude inside the seed's §7.1
// SR_DFPC_0100/0101), with cdff::eval's statistics; and bad input (empty scans, NaNs, scans
// with no point on the target, a missing model file) reported as events while the filter coasts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <map>

#include "cdff/types/geometry.hpp"
#include "lidar_tracking_support.hpp"
#include "support/synthetic.hpp"

namespace cdff::lidar_tracking {
namespace {

constexpr double kDeg = M_PI / 180.0;

void record(const std::string& name, const TrackingResult& r) {
  const eval::PoseEvaluation& e = r.evaluation;
  ::testing::Test::RecordProperty(
      name, fmt::format("position p95 {:.4f} m ({:.3f} % of range), rmse {:.4f} m; angle p95 "
                        "{:.3f} deg; tracked {}/{} scans ({:.2f} %); {} matched products",
                        e.position_error_m.p95, e.position_error_pct_range.p95,
                        e.position_error_m.rmse, e.angle_error_deg.p95, r.accepted, r.scans,
                        100.0 * r.tracked_fraction, e.matched_frames));
  std::cout << name << ": " << e.position_error_m.p95 << " m p95 ("
            << e.position_error_pct_range.p95 << " % of range), " << e.angle_error_deg.p95
            << " deg p95, max " << e.position_error_m.max << " m / " << e.angle_error_deg.max
            << " deg, tracked " << r.accepted << "/" << r.scans << "\n";
  std::map<std::string, int> events;
  for (const dfpc::Event& ev : r.events) {
    if (ev.kind() == dfpc::EventKind::kLifecycle) continue;
    const std::string what = ev.instance + " " + toString(ev.type);
    if (std::getenv("CDFF_TEST_VERBOSE") && ev.type == dfpc::EventType::kDivergence)
      std::cout << "  " << toSeconds(ev.stamp) << " s: " << what << "\n";
    if (events[what]++ < 2) std::cout << "  e.g. " << what << ": " << ev.message << "\n";
  }
  for (const auto& [what, n] : events) std::cout << "  " << what << ": " << n << "\n";
}

std::size_t countEvents(const TrackingResult& r, dfpc::EventType type, const std::string& instance,
                        const std::string& fragment = "") {
  std::size_t n = 0;
  for (const dfpc::Event& e : r.events)
    if (e.type == type && e.instance == instance && e.message.find(fragment) != std::string::npos)
      ++n;
  return n;
}

// The first second after the initial state is the acquisition (the ICP pulls the 10 %, 10 degree
// error in over a few scans); the targets apply to tracking.
constexpr double kSettle = 1.0;

TEST(LidarTracking, MidRangeApproach) {
  Result<SimulatedRun> run = simulate("mid_range_approach", 0);
  ASSERT_OK(run.status());
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 7);
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("mid_range", *r);
  EXPECT_GT(r->evaluation.max_range_m, 15.0);
  EXPECT_LT(r->evaluation.min_range_m, 2.5);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 0.5);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 1.0);
  EXPECT_GE(r->tracked_fraction, 0.99);
  EXPECT_EQ(countEvents(*r, dfpc::EventType::kReinitialise, "ekf"), 0u);
}

TEST(LidarTracking, CloseRangeApproach) {
  Result<SimulatedRun> run = simulate("close_range_approach", 0);
  ASSERT_OK(run.status());
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 8);
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("close_range", *r);
  EXPECT_LE(r->evaluation.position_error_m.p95, 0.01);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 0.5);
  EXPECT_GE(r->tracked_fraction, 0.99);
}

TEST(LidarTracking, TumblingTargetWithDroppedScans) {
  // 5 deg/s tumbling (|[2, -3, 3.5]| deg/s) and 20 % of the scans not published.
  Result<SimulatedRun> run = simulate(
      "tumbling_target", 0,
      "faults:\n  - {type: dropped_frames, sensor: lidar, start: 0, end: 1000, probability: 0.2}");
  ASSERT_OK(run.status());
  // Tracking, not acquisition, is under test here: started from 1 % of the range and 1 degree.
  // (From 10 % and 10 degrees at 15 m, the ~40 points on the tumbling target lead the ICP into
  // a wrong local minimum for the seeds tried; see docs/lidar-tracking.md, limits.)
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.01, 1.0 * kDeg, 9);
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("tumbling_dropped", *r);
  // 90 s at 10 Hz with 20 % dropped: about 720 scans arrive.
  EXPECT_LT(r->scans, 780u);
  EXPECT_GT(r->scans, 660u);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 2 * 0.5);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 2 * 1.0);
  EXPECT_GE(r->tracked_fraction, 0.98);
}

// Replaces the scans in [from, to) s after the first one by `make(scan)`.
template <typename F>
std::vector<dfpc::Message> corrupt(const SimulatedRun& run, double from, double to, F make) {
  std::vector<dfpc::Message> out;
  const Timestamp t0 = run.scans.front().stamp;
  for (const dfpc::Message& m : run.messages) {
    const PointCloud* scan = m.as<PointCloud>();
    if (scan && m.stamp >= t0 + fromSeconds(from) && m.stamp < t0 + fromSeconds(to))
      out.push_back(dfpc::Message::of(m.channel, m.stamp, make(*scan)));
    else
      out.push_back(m);
  }
  return out;
}

TEST(LidarTracking, BadScansAreReportedAndTheFilterCoasts) {
  Result<SimulatedRun> run = simulate("mid_range_approach", 30);
  ASSERT_OK(run.status());
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 10);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // 5-6 s: empty scans; 6-7 s: every point NaN; 7-8 s: half the points NaN (still trackable);
  // 8-9 s: no point on the target (everything 60 m away).
  std::vector<dfpc::Message> messages = corrupt(*run, 5, 6, [](const PointCloud& s) {
    PointCloud empty;
    empty.stamp = s.stamp;
    empty.frame_id = s.frame_id;
    return empty;
  });
  SimulatedRun copy = *run;
  copy.messages = messages;
  messages = corrupt(copy, 6, 7, [&](const PointCloud& s) {
    PointCloud bad = s;
    std::vector<Point4f> points(s.points.begin(), s.points.end());
    for (Point4f& p : points) p = Point4f(nan, nan, nan);
    bad.points = Buffer<Point4f>::fromVector(std::move(points));
    return bad;
  });
  copy.messages = messages;
  messages = corrupt(copy, 7, 8, [&](const PointCloud& s) {
    PointCloud bad = s;
    std::vector<Point4f> points(s.points.begin(), s.points.end());
    for (std::size_t i = 0; i < points.size(); i += 2) points[i] = Point4f(nan, 0.0f, nan);
    bad.points = Buffer<Point4f>::fromVector(std::move(points));
    return bad;
  });
  copy.messages = messages;
  messages = corrupt(copy, 8, 9, [&](const PointCloud& s) {
    PointCloud away;
    away.stamp = s.stamp;
    away.frame_id = s.frame_id;
    std::vector<Point4f> points;
    for (int i = 0; i < 500; ++i) points.emplace_back(60.0f, 0.01f * static_cast<float>(i), 3.0f);
    away.points = Buffer<Point4f>::fromVector(std::move(points));
    return away;
  });
  Result<TrackingResult> r = track(*run, messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("bad_scans", *r);
  // Each bad scan is an event naming the problem: an empty scan is rejected by the filter; a
  // scan of NaNs or with no point near the target leaves nothing after the filter (a warning)
  // and the registration reports its empty input.
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnError, "filter", "input 'cloud' has no points"),
            9u);
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnWarning, "filter", "passed the filters"), 19u);
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnError, "icp", "input 'source' has no points"),
            19u);
  // The filter coasts: a state every 50 ms through the 3 s without a usable scan...
  const Timestamp t0 = run->scans.front().stamp;
  std::size_t coasting = 0;
  double worst_sigma = 0;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/pose" && m.stamp >= t0 + fromSeconds(5.05) &&
        m.stamp < t0 + fromSeconds(7.0)) {
      ++coasting;
      worst_sigma = std::max(worst_sigma, std::sqrt(m.as<RigidBodyState>()->covariance(0, 0)));
    }
  EXPECT_GE(coasting, 38u);
  EXPECT_GT(worst_sigma, 0.0);
  // ...and the scans with half their points NaN are still tracked; tracking resumes after the
  // bad scans, within the mid-range targets.
  EXPECT_EQ(countEvents(*r, dfpc::EventType::kReinitialise, "ekf"), 0u);
  std::vector<eval::MatchedError> after;
  for (const eval::MatchedError& e : r->evaluation.errors)
    if (e.stamp >= t0 + fromSeconds(10.0)) after.push_back(e);
  ASSERT_GT(after.size(), 100u);
  std::vector<double> pct, angle;
  for (const eval::MatchedError& e : after) {
    pct.push_back(100.0 * e.position_error_m / e.range_m);
    angle.push_back(e.angle_error_deg);
  }
  EXPECT_LE(eval::ErrorStatistics::of(pct).p95, 0.5);
  EXPECT_LE(eval::ErrorStatistics::of(angle).p95, 1.0);
  std::size_t half_nan_tracked = 0;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/accepted" && m.stamp >= t0 + fromSeconds(7.0) &&
        m.stamp < t0 + fromSeconds(8.0) && *m.as<bool>())
      ++half_nan_tracked;
  EXPECT_GE(half_nan_tracked, 9u);
}

TEST(LidarTracking, AMissingModelFileIsReportedAndNothingCrashes) {
  Result<SimulatedRun> run = simulate("mid_range_approach", 5);
  ASSERT_OK(run.status());
  SimulatedRun missing = *run;
  missing.mesh_file = "/nonexistent/target_satellite.ply";
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 11);
  Result<TrackingResult> r = track(missing, run->messages, initial, 0.0);
  ASSERT_OK(r.status());
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnError, "model",
                        "mesh file '/nonexistent/target_satellite.ply' does not exist"),
            4u);
  // No model, no registration: the EKF only predicts from the initial state.
  EXPECT_EQ(r->accepted, 0u);
  EXPECT_GT(r->evaluation.frames, 80u);
}

}  // namespace
}  // namespace cdff::lidar_tracking
