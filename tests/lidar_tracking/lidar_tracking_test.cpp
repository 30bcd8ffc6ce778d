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
#include <set>

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
            << " deg, tracked " << r.accepted << "/" << r.scans << "; NEES mean "
            << e.covariance.nees_mean << " (6 if honest; position "
            << e.covariance.position_nees_mean << ", attitude " << e.covariance.attitude_nees_mean
            << "), " << 100 * e.covariance.within_95_fraction << " % within the 95 % bound\n";
  std::map<std::string, int> events;
  for (const dfpc::Event& ev : r.events) {
    if (ev.type == dfpc::EventType::kTrackStateChanged)
      std::cout << "  " << toSeconds(ev.stamp) << " s: track " << ev.message << "\n";
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

// The stamps of the track state changes "FROM -> TO" (any FROM when empty).
std::vector<Timestamp> trackChanges(const TrackingResult& r, const std::string& to,
                                    const std::string& from = "") {
  std::vector<Timestamp> stamps;
  for (const dfpc::Event& e : r.events)
    if (e.type == dfpc::EventType::kTrackStateChanged && e.message.ends_with("-> " + to) &&
        (from.empty() || e.message.starts_with(from + " ->")))
      stamps.push_back(e.stamp);
  return stamps;
}

// p95 of the position error (% of range) and of the angle error (deg) from `from` on.
std::pair<double, double> p95After(const TrackingResult& r, Timestamp from) {
  std::vector<double> pct, angle;
  for (const eval::MatchedError& e : r.evaluation.errors)
    if (e.stamp >= from) {
      pct.push_back(100.0 * e.position_error_m / e.range_m);
      angle.push_back(e.angle_error_deg);
    }
  if (pct.empty())
    return {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  return {eval::ErrorStatistics::of(pct).p95, eval::ErrorStatistics::of(angle).p95};
}

// The pose product's covariance describes its errors: the mean NEES is within a factor of 4 of
// the 6 an honest covariance gives, i.e. the covariance's scale is within a factor of 2 (in
// sigma) of the errors' spread. The EKF gates the registrations with it and a user plans with
// it; over an approach the errors are correlated, so a tighter band would test luck.
void expectHonestCovariance(const TrackingResult& r) {
  EXPECT_GT(r.evaluation.covariance.count, 100u);
  EXPECT_GE(r.evaluation.covariance.nees_mean, 6.0 / 4);
  EXPECT_LE(r.evaluation.covariance.nees_mean, 6.0 * 4);
}

// The first second after the initial state is the acquisition (the ICP pulls the 10 %, 10 degree
// error in over a few scans); the targets apply to tracking.
constexpr double kSettle = 1.0;

// 20 % of the LIDAR's scans not published (the tumbling scenarios).
const std::string kDroppedScans =
    "faults:\n  - {type: dropped_frames, sensor: lidar, start: 0, end: 1000, probability: 0.2}";

// The first CI draw of the evaluation set (data/evaluation/draws.yaml): its own simulator seed
// and initial error. All evaluation draws run in bench/lidar_tracking_accuracy_bench.cpp.
eval::Draw firstCiDraw() {
  const std::vector<eval::Draw> draws = drawSets().ciDraws();
  return draws.empty() ? eval::Draw{} : draws.front();
}

TEST(LidarTracking, MidRangeApproach) {
  Result<DrawnRun> d = simulateDraw(firstCiDraw(), "mid_range_approach", 0, 0.10, 10.0 * kDeg);
  ASSERT_OK(d.status());
  const SimulatedRun* run = &d->run;
  const RigidBodyState& initial = d->initial;
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("mid_range", *r);
  EXPECT_GT(r->evaluation.max_range_m, 15.0);
  EXPECT_LT(r->evaluation.min_range_m, 2.5);
  // The goal (p95 0.5 % of the range, 1 degree, 99 % tracked), and 1.5 times today's p95
  // (0.096 %, 0.372 degrees) against a regression.
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 0.5);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 1.0);
  EXPECT_GE(r->tracked_fraction, 0.99);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 1.5 * 0.096);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 1.5 * 0.372);
  EXPECT_EQ(countEvents(*r, dfpc::EventType::kReinitialise, "ekf"), 0u);
  expectHonestCovariance(*r);
}

TEST(LidarTracking, CloseRangeApproach) {
  Result<DrawnRun> d = simulateDraw(firstCiDraw(), "close_range_approach", 0, 0.10, 10.0 * kDeg);
  ASSERT_OK(d.status());
  const SimulatedRun* run = &d->run;
  const RigidBodyState& initial = d->initial;
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("close_range", *r);
  // The goal (p95 10 mm, 0.5 degrees, 99 % tracked), and 1.5 times today's p95 (4.42 mm,
  // 0.187 degrees) against a regression.
  EXPECT_LE(r->evaluation.position_error_m.p95, 0.01);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 0.5);
  EXPECT_GE(r->tracked_fraction, 0.99);
  EXPECT_LE(r->evaluation.position_error_m.p95, 1.5 * 0.00442);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 1.5 * 0.187);
  expectHonestCovariance(*r);
}

TEST(LidarTracking, TumblingTargetWithDroppedScans) {
  // 5 deg/s tumbling (|[2, -3, 3.5]| deg/s) and 20 % of the scans not published.
  // Acquisition from the 10 % of the range and 10 degrees at 15 m, where the scan has
  // about 40 points on the target after the voxel grid (a single ICP run from the initial state
  // falls into a wrong local minimum there; the DFPC's multi-start acquisition does not).
  Result<DrawnRun> d =
      simulateDraw(firstCiDraw(), "tumbling_target", 0, 0.10, 10.0 * kDeg, kDroppedScans);
  ASSERT_OK(d.status());
  const SimulatedRun* run = &d->run;
  const RigidBodyState& initial = d->initial;
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("tumbling_dropped", *r);
  // 90 s at 10 Hz with 20 % dropped: about 720 scans arrive.
  EXPECT_LT(r->scans, 780u);
  EXPECT_GT(r->scans, 660u);
  // Twice the mid-range goal, and 1.5 times today's p95 (0.113 %, 0.71 degrees).
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 2 * 0.5);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 2 * 1.0);
  EXPECT_GE(r->tracked_fraction, 0.99);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 1.5 * 0.113);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 1.5 * 0.71);
  // Acquired once, then tracked throughout (dropped scans are shorter than the 1 s loss limit).
  EXPECT_EQ(trackChanges(*r, "TRACKING").size(), 1u);
  EXPECT_TRUE(trackChanges(*r, "LOST").empty());
  expectHonestCovariance(*r);
}

// Today's figures on the CI draws (TheCiDrawsKeepTodaysFigures prints them).
constexpr std::size_t kTodaysWithinGoal = 8;
constexpr std::size_t kTodaysWrongLockDraws = 0;
constexpr double kTodaysPositionP95Pct = 0.104;
constexpr double kTodaysAngleP95Deg = 1.38;

// Acquisition on the tumbling target, one evaluation draw each (its own simulator seed: scan
// noise, dropped scans; its own Gaussian initial error of RMS 10 % of the range and 10 degrees).
// 30 s of the scenario (15 -> 11.7 m, the sparse end), 20 % of the scans dropped.
struct DrawRun {
  TrackingResult result;
  std::size_t wrong_tracking = 0;  // pose products reported TRACKING that are a wrong lock
  double worst_tracking_deg = 0;
  double worst_tracking_pct = 0;
};

void runDraw(std::uint64_t number, DrawRun& out, const GraphEdit& edit = {}) {
  double duration = 30;
  if (const char* d = std::getenv("CDFF_TUMBLING_DURATION")) duration = std::atof(d);
  Result<DrawnRun> d = simulateDraw(eval::drawOf(number), "tumbling_target", duration, 0.10,
                                    10.0 * kDeg, kDroppedScans);
  ASSERT_OK(d.status());
  const SimulatedRun& run = d->run;
  const RigidBodyState& initial = d->initial;
  Result<TrackingResult> r = track(run, run.messages, initial, kSettle, edit);
  ASSERT_OK(r.status());
  record(fmt::format("tumbling_draw_{}{}", number, edit ? "_edited" : ""), *r);
  // Every pose product reported TRACKING, from the initial state on, against the truth.
  Result<ReportedTracking> reported = reportedTracking(*r, run.truth);
  ASSERT_OK(reported.status());
  ASSERT_GT(reported->errors.size(), 100u);
  out.wrong_tracking = reported->wrong_locks;
  out.worst_tracking_deg = reported->worst_deg;
  out.worst_tracking_pct = reported->worst_pct;
  if (std::getenv("CDFF_TEST_VERBOSE"))
    for (const eval::MatchedError& e : reported->errors)
      if (toSeconds(e.stamp - initial.pose.stamp) < 5.0)
        std::cout << "  " << toSeconds(e.stamp - initial.pose.stamp) << " s TRACKING "
                  << e.position_error_m << " m " << e.angle_error_deg << " deg\n";
  std::cout << "draw " << number << ": worst reported TRACKING " << out.worst_tracking_deg
            << " deg, " << out.worst_tracking_pct << " % of range\n";
  out.result = std::move(r).value();
}

// The CI draws of the evaluation set, each simulated with its own seed and started from its own
// Gaussian initial error. The goal (every draw within twice the mid-range targets, >= 99 % of
// the scans tracked, no wrong lock reported TRACKING, in >= 98 % of the draws) is not met today
// (docs/lidar-tracking.md, Limits; lidar_tracking_accuracy_bench reports it over the 50
// evaluation draws). This test guards today's figures on the CI draws against a regression:
// the count of draws that meet the goal and of draws with a wrong lock, and the p95 errors over
// every draw's poses together within 1.5 times today's.
TEST(TumblingAcquisition, TheCiDrawsKeepTodaysFigures) {
  std::vector<double> pct, angle;
  std::size_t within_goal = 0, wrong_lock_draws = 0, draws = 0;
  for (const eval::Draw& draw : drawSets().ciDraws()) {
    DrawRun d;
    ASSERT_NO_FATAL_FAILURE(runDraw(draw.number, d));
    const eval::PoseEvaluation& e = d.result.evaluation;
    for (const eval::MatchedError& m : e.errors) {
      pct.push_back(100.0 * m.position_error_m / m.range_m);
      angle.push_back(m.angle_error_deg);
    }
    ++draws;
    wrong_lock_draws += d.wrong_tracking > 0;
    within_goal += d.wrong_tracking == 0 && e.position_error_pct_range.p95 <= 2 * 0.5 &&
                   e.angle_error_deg.p95 <= 2 * 1.0 && d.result.tracked_fraction >= 0.99;
  }
  const double pct_p95 = eval::ErrorStatistics::of(pct).p95;
  const double angle_p95 = eval::ErrorStatistics::of(angle).p95;
  std::printf(
      "%zu CI draws: %zu within the goal, %zu with a wrong lock reported TRACKING; "
      "p95 over all draws %.3f %% of range, %.2f deg\n",
      draws, within_goal, wrong_lock_draws, pct_p95, angle_p95);
  ASSERT_EQ(draws, drawSets().ci);
  EXPECT_GE(within_goal, kTodaysWithinGoal);
  EXPECT_LE(wrong_lock_draws, kTodaysWrongLockDraws);
  EXPECT_LE(pct_p95, 1.5 * kTodaysPositionP95Pct);
  EXPECT_LE(angle_p95, 1.5 * kTodaysAngleP95Deg);
}

TEST(LidarTracking, ALostTargetIsReportedAndReacquired) {
  // 10-13 s: scans with no point on the target (it is out of view). The track goes LOST after
  // 1 s without a fused registration, the filter coasts, and the target is re-acquired from the
  // coasted state once it is back; the DFPC's track state says so (events in the recording).
  Result<SimulatedRun> run = simulate("tumbling_target", 30);
  ASSERT_OK(run.status());
  // Started close to the truth: the loss and the re-acquisition are under test here.
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.01, 1.0 * kDeg, 12);
  const Timestamp t0 = run->scans.front().stamp;
  std::vector<dfpc::Message> messages;
  for (const dfpc::Message& m : run->messages) {
    const PointCloud* scan = m.as<PointCloud>();
    if (!scan || m.stamp < t0 + fromSeconds(10) || m.stamp >= t0 + fromSeconds(13)) {
      messages.push_back(m);
      continue;
    }
    PointCloud away;
    away.stamp = scan->stamp;
    away.frame_id = scan->frame_id;
    std::vector<Point4f> points;
    for (int i = 0; i < 500; ++i) points.emplace_back(60.0f, 0.01f * static_cast<float>(i), 3.0f);
    away.points = Buffer<Point4f>::fromVector(std::move(points));
    messages.push_back(dfpc::Message::of(m.channel, m.stamp, away));
  }
  Result<TrackingResult> r = track(*run, messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("lost_and_reacquired", *r);
  // Under test is the loss while the target is away and the re-acquisition once it is back:
  // the changes from 5 s on. (A loss in the first seconds, while the filter's velocity settles,
  // is an acquisition matter: the tracked fraction of the TumblingAcquisition draws counts it.)
  std::vector<Timestamp> lost = trackChanges(*r, "LOST", "TRACKING");
  std::erase_if(lost, [&](Timestamp t) { return t < t0 + fromSeconds(5); });
  ASSERT_EQ(lost.size(), 1u);
  // The last fused scan is at about 9.9 s: LOST 1 s later, while the target is away.
  EXPECT_GE(lost.front(), t0 + fromSeconds(10.8));
  EXPECT_LE(lost.front(), t0 + fromSeconds(11.2));
  std::vector<Timestamp> back = trackChanges(*r, "TRACKING", "LOST");
  std::erase_if(back, [&](Timestamp t) { return t < t0 + fromSeconds(5); });
  ASSERT_EQ(back.size(), 1u);
  EXPECT_GE(back.front(), t0 + fromSeconds(13.0));
  EXPECT_LE(back.front(), t0 + fromSeconds(14.0));
  // Coasting: a state every 50 ms while lost.
  std::size_t coasting = 0;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/pose" && m.stamp >= lost.front() &&
        m.stamp < back.front())
      ++coasting;
  EXPECT_GE(coasting, static_cast<std::size_t>(toSeconds(back.front() - lost.front()) / 0.05) - 1);
  // The track_state product follows, and tracking after re-acquisition meets the targets.
  std::size_t lost_products = 0;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/track_state" && *m.as<TrackState>() == TrackState::kLost)
      ++lost_products;
  EXPECT_GE(lost_products, 30u);
  const auto [pct, angle] = p95After(*r, back.front() + fromSeconds(kSettle));
  EXPECT_LE(pct, 2 * 0.5);
  EXPECT_LE(angle, 2 * 1.0);
}

TEST(LidarTracking, TheAhrsAttitudeIsFused) {
  // The simulator's AHRS (servicer attitude, 0.2 deg noise) at 20 Hz, between the scans: the
  // EKF corrects with every sample (seed §4.1.4); the errors are compared with the same run
  // without it.
  Result<SimulatedRun> run =
      simulate("tumbling_target", 30, "", 1,
               {"sensors.ahrs.enabled=true", "sensors.ahrs.rate=20", "sensors.ahrs.phase=0.025"});
  ASSERT_OK(run.status());
  std::set<Timestamp> ahrs_stamps;
  std::vector<dfpc::Message> without;
  for (const dfpc::Message& m : run->messages) {
    if (m.channel == "/chaser/ahrs/attitude")
      ahrs_stamps.insert(m.stamp);
    else
      without.push_back(m);
  }
  ASSERT_GE(ahrs_stamps.size(), 590u);
  // Started close to the truth: the AHRS correction, not the acquisition, is under test.
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.01, 1.0 * kDeg, 9);
  Result<TrackingResult> r = track(*run, run->messages, initial, kSettle);
  ASSERT_OK(r.status());
  record("tumbling_ahrs", *r);
  Result<TrackingResult> plain = track(*run, without, initial, kSettle);
  ASSERT_OK(plain.status());
  record("tumbling_no_ahrs", *plain);
  // Every AHRS sample after the first (which adds the target's inertial attitude to the state)
  // is fused, with a normalised innovation consistent with its 3 degrees of freedom.
  const Timestamp from = initial.pose.stamp + fromSeconds(kSettle);
  std::size_t fused = 0, samples = 0;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/accepted" && m.stamp >= from &&
        ahrs_stamps.count(m.stamp)) {
      ++samples;
      if (*m.as<bool>()) ++fused;
    }
  std::vector<double> nis;
  for (const dfpc::Message& m : r->products)
    if (m.channel == "/cdff/lidar_tracking/nis" && m.stamp >= from && ahrs_stamps.count(m.stamp) &&
        std::isfinite(*m.as<double>()))
      nis.push_back(*m.as<double>());
  ASSERT_GE(samples, 560u);
  EXPECT_GE(fused, samples * 99 / 100);
  ASSERT_FALSE(nis.empty());
  double mean_nis = 0;
  for (double v : nis) mean_nis += v / static_cast<double>(nis.size());
  std::cout << "AHRS: " << fused << "/" << samples << " fused, mean NIS " << mean_nis << "\n";
  EXPECT_LE(mean_nis, 2 * 3.0);
  EXPECT_LE(r->evaluation.position_error_pct_range.p95, 2 * 0.5);
  EXPECT_LE(r->evaluation.angle_error_deg.p95, 2 * 1.0);
  EXPECT_GE(r->tracked_fraction, 0.99);
  // The AHRS attitude is used: the estimates differ from the run without it.
  EXPECT_NE(r->evaluation.angle_error_deg.p95, plain->evaluation.angle_error_deg.p95);
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
  // Each bad scan is an event naming the problem: an empty scan is rejected by the first node
  // that sees it (the motion compensation); a scan of NaNs or with no point near the target
  // leaves nothing after the filter (a warning) and the registration reports its empty input.
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnError, "deskew", "input 'cloud' has no points"),
            9u);
  EXPECT_GE(countEvents(*r, dfpc::EventType::kDfnWarning, "filter", "passed the filters"), 19u);
  // (the registration is `icp` while tracking, `acquire` once the track is lost).
  EXPECT_GE(
      countEvents(*r, dfpc::EventType::kDfnError, "icp", "input 'source' has no points") +
          countEvents(*r, dfpc::EventType::kDfnError, "acquire", "input 'source' has no points"),
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
  // Two seconds without a usable scan (5-7 s): LOST about 1 s after the last fused one, back to
  // TRACKING with the half-NaN scans at 7 s; the 1 s of scans with no target (8-9 s) stays
  // within the loss limit or goes LOST and comes back at 9 s.
  const std::vector<Timestamp> lost = trackChanges(*r, "LOST", "TRACKING");
  ASSERT_GE(lost.size(), 1u);
  EXPECT_GE(lost.front(), t0 + fromSeconds(5.8));
  EXPECT_LE(lost.front(), t0 + fromSeconds(6.2));
  const std::vector<Timestamp> back = trackChanges(*r, "TRACKING", "LOST");
  ASSERT_EQ(back.size(), lost.size());
  EXPECT_GE(back.front(), t0 + fromSeconds(7.0));
  EXPECT_LE(back.front(), t0 + fromSeconds(7.3));
  for (Timestamp t : back) EXPECT_LE(t, t0 + fromSeconds(9.5));
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

// The model's mesh file is read when the graph is built: a missing file stops the DFPC from
// starting, with the graph file, the instance and the file's name, instead of a run whose model
// node faults at every scan.
TEST(LidarTracking, AMissingModelFileStopsTheGraphFromStartingAndSaysWhere) {
  Result<SimulatedRun> run = simulate("mid_range_approach", 5);
  ASSERT_OK(run.status());
  SimulatedRun missing = *run;
  missing.mesh_file = "/nonexistent/target_satellite.ply";
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 11);
  Result<TrackingResult> r = track(missing, run->messages, initial, 0.0);
  ASSERT_FALSE(r.isOk());
  EXPECT_EQ(r.status().code(), StatusCode::kNotFound) << r.status().toString();
  for (const char* fragment : {"lidar_tracking.yaml:", "instance 'model'", "parameter 'mesh_file'",
                               "mesh file '/nonexistent/target_satellite.ply' does not exist"})
    EXPECT_NE(r.status().message().find(fragment), std::string::npos)
        << "'" << fragment << "' not in: " << r.status().message();
}

// The graph takes the LIDAR's geometry from its description (/chaser/lidar/info), not from
// constants: a run without it is refused before anything runs, naming the input and the
// channel; a description of another sensor frame than the scans' is an error of `acquire`
// naming both frames, at every scan it would register.
TEST(LidarTracking, TheLidarDescriptionIsRequiredAndMustBeTheScansSensor) {
  Result<SimulatedRun> run = simulate("mid_range_approach", 2);
  ASSERT_OK(run.status());
  const RigidBodyState initial =
      perturbedInitialState(run->truth, run->scans.front().stamp, 0.10, 10.0 * kDeg, 11);
  std::vector<dfpc::Message> without, other;
  for (const dfpc::Message& m : run->messages) {
    if (const LidarInfo* info = m.as<LidarInfo>()) {
      LidarInfo moved = *info;
      moved.frame_id = "velodyne";
      other.push_back(dfpc::Message::of(m.channel, m.stamp, moved));
      continue;
    }
    without.push_back(m);
    other.push_back(m);
  }
  ASSERT_LT(without.size(), run->messages.size());
  Result<TrackingResult> r = track(*run, without, initial, 0.0);
  ASSERT_FALSE(r.isOk());
  EXPECT_EQ(r.status().code(), StatusCode::kNotFound) << r.status().toString();
  EXPECT_NE(r.status().message().find("input 'lidar_info' needs channel '/chaser/lidar/info' "
                                      "(LidarInfo), which the input does not have"),
            std::string::npos)
      << r.status().message();

  r = track(*run, other, initial, 0.0);
  ASSERT_OK(r.status());
  const std::size_t errors = countEvents(*r, dfpc::EventType::kDfnError, "acquire");
  EXPECT_GE(errors, 10u) << "one per scan that reaches `acquire`";
  EXPECT_EQ(countEvents(*r, dfpc::EventType::kDfnError, "acquire",
                        "input 'sensor' describes the LIDAR of frame 'velodyne' but input "
                        "'source' is in frame 'lidar'"),
            errors);
  EXPECT_EQ(r->accepted, 0u);
}

}  // namespace
}  // namespace cdff::lidar_tracking
