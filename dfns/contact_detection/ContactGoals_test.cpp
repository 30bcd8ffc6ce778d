// The haptic contact goals of issue 21 on the simulator's arm: random collision paths towards
// the box target from several seeds, the measured joints through ForwardKinematics (to the
// sensor's link) and the measured wrench through ContactDetection; each contact's last estimate
// taken to the target frame with the true target pose and compared with the truth. Every true
// contact counts; each should be a path's (started on its approach: the transits and the ways
// home are planned clear of the target). The sensor's noise is the simulator's default (0.02 N, 1
// mN m per axis; 20 urad encoders). Both DFIs run on the same samples: HysteresisLineOfAction
// meets the goals; ForceThreshold, the 2019 approach, is measured beside it for comparison.
// CDFF_HAPTIC_PATHS sets the paths per seed (default 20; docs/haptic-scanning.md has the figures
// for 1000 paths and the command).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <vector>

#include "ContactDetection.gen.hpp"
#include "ForwardKinematics.gen.hpp"
#include "cdff/egse/arm_simulator.hpp"
#include "cdff/egse/procedural.hpp"
#include "support/dfn_testing.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;
const std::string kArm = std::string(CDFF_SOURCE_DIR) + "/data/arms/servicer_arm.urdf";

/// The box target's +x face 0.85 m ahead of the arm's base, turning slowly (+-3 deg about its
/// z over a minute) and drifting (+-2 cm along the base's y): the arm follows it.
Eigen::Isometry3d baseTTarget(double t) {
  return Eigen::Translation3d(1.45, 0.02 * std::sin(2 * M_PI * t / 45), 0.35) *
         Eigen::AngleAxisd(M_PI + 3 * kDeg * std::sin(2 * M_PI * t / 60), Eigen::Vector3d::UnitZ());
}

/// One DFI's figures over the run.
struct Tally {
  int true_contacts = 0, detected = 0, estimated = 0, detections = 0, false_detections = 0;
  int faults = 0;
  std::vector<double> point_errors, normal_errors;
  // The true force's angle from the true normal (friction) at the sample of each estimate.
  std::vector<double> friction_tilts;
  // Every estimate given while in contact (the map takes them all), and the tilt at each.
  std::vector<double> sample_normal_errors, sample_tilts;
};

/// What both DFIs see: the simulator's paths and its true contacts.
struct PathsRun {
  int paths = 0, abandoned = 0, off_approach = 0;
  Tally hysteresis, threshold;  // HysteresisLineOfAction, ForceThreshold
  bool complete = false;        // every seed ran to its end
};

/// A ContactDetection DFI on the run's samples, its events matched with the truth's contacts.
struct Detector {
  Detector(std::unique_ptr<ContactDetection> detection, Tally& t)
      : dfn(std::move(detection)), tally(t) {}

  std::unique_ptr<ContactDetection> dfn;
  Tally& tally;
  bool in_detected = false, detected_this = false, overlapped = false;
  std::optional<std::array<double, 3>> last_error;  // point, normal, friction tilt

  void step(std::uint64_t seed, const egse::ArmSample& sample,
            const Eigen::Isometry3d& base_T_target, const Eigen::Isometry3d& base_T_sensor,
            bool truth_started, bool truth_ended) {
    const egse::ArmTruth& truth = sample.truth;
    dfn->in.wrench.set(sample.wrench);
    // A saturated sample is a fault the DFN reports; the contact state stays as it was.
    if (const Status s = dfn->process(); !s.isOk()) {
      if (tally.faults++ == 0)
        std::printf("first fault (seed %d): %s\n", static_cast<int>(seed), s.message().c_str());
      EXPECT_TRUE(truth.saturated) << s.message();
    }
    const bool detected = *dfn->out.in_contact;
    // Events: a true contact is detected when a detection overlaps it; a detection that
    // overlaps no true contact is false.
    if (truth_started) {
      detected_this = false;
      last_error.reset();
    }
    if (detected && !in_detected) {
      ++tally.detections;
      overlapped = false;
    }
    if (detected && truth.in_contact) detected_this = overlapped = true;
    if (dfn->out.contact.hasValue() && dfn->out.contact->stamp == sample.wrench.stamp &&
        truth.in_contact) {
      const PointCloud& c = *dfn->out.contact;
      const Eigen::Isometry3d target_T_sensor = base_T_target.inverse() * base_T_sensor;
      const Eigen::Vector3d point = target_T_sensor * c.points[0].vec().cast<double>();
      const Eigen::Vector3d normal = target_T_sensor.linear() * c.normals[0].vec().cast<double>();
      const double tilt = std::acos(
          std::clamp(truth.contact_force.normalized().dot(truth.contact_normal), -1.0, 1.0));
      last_error = {(point - truth.contact_point).norm(),
                    std::acos(std::clamp(normal.dot(truth.contact_normal), -1.0, 1.0)), tilt};
      tally.sample_normal_errors.push_back((*last_error)[1]);
      tally.sample_tilts.push_back(tilt);
    }
    if (truth_ended) {
      ++tally.true_contacts;
      tally.detected += detected_this;
      if (last_error) {
        ++tally.estimated;
        tally.point_errors.push_back((*last_error)[0]);
        tally.normal_errors.push_back((*last_error)[1]);
        tally.friction_tilts.push_back((*last_error)[2]);
      }
    }
    if (!detected && in_detected && !overlapped) ++tally.false_detections;
    in_detected = detected;
  }
};

/// The 2019 approach's threshold on the raw force's norm, set as it would be: above the sensor's
/// turn-on bias, which it does not remove. The bias's norm (three axes of sigma 0.5 N) exceeds
/// 4 sigmas (2 N, the DFI's default) in about one run in 900, and a press of 10 N is five times it.
double thresholdOf2019(const egse::ForceTorqueSpec& sensor) {
  return 4 * sensor.force_bias_sigma;
}

/// One seed's run through the chain, both DFIs on the same samples, tallied per contact.
void runSeed(std::uint64_t seed, int paths, PathsRun& run) {
  egse::ArmSpec spec;
  spec.description = kArm;
  auto sim = egse::ArmSimulator::create(spec, egse::makeTargetSatellite().value(), seed);
  ASSERT_OK(sim.status());
  auto kinematics = testing::makeDfn<ForwardKinematics>(
      "ForwardKinematics", "Kdl", "{description: " + kArm + ", link: ft_sensor}");
  // The DFIs' parameters from the sensor's and the tool's figures.
  const Eigen::Vector3d tip = (*sim)->tipInSensor();
  const std::string tool = fmt::format("tip_centre: [{}, {}, {}], tip_radius: {}", tip.x(), tip.y(),
                                       tip.z(), (*sim)->tipRadius());
  Detector hysteresis{
      testing::makeDfn<ContactDetection>(
          "ContactDetection", "HysteresisLineOfAction",
          fmt::format("{{{}, force_noise: {}, torque_noise: {}}}", tool,
                      spec.force_torque.force_noise, spec.force_torque.torque_noise)),
      run.hysteresis};
  Detector threshold{
      testing::makeDfn<ContactDetection>(
          "ContactDetection", "ForceThreshold",
          fmt::format("{{{}, threshold: {}}}", tool, thresholdOf2019(spec.force_torque))),
      run.threshold};
  bool in_true = false;
  while ((*sim)->pathsStarted() <= paths) {
    const double t = toSeconds((*sim)->time() + 1000);
    const Eigen::Isometry3d base_T_target = baseTTarget(t);
    Result<egse::ArmSample> sample = (*sim)->step(base_T_target);
    ASSERT_TRUE(sample.isOk()) << "seed " << seed << ": " << sample.status().message();
    const egse::ArmTruth& truth = sample->truth;
    kinematics->in.joints.set(sample->joints);
    ASSERT_OK(kinematics->process());
    const bool started = truth.in_contact && !in_true, ended = !truth.in_contact && in_true;
    if (started) run.off_approach += truth.phase != egse::ArmPhase::kApproach;
    const Eigen::Isometry3d base_T_sensor = kinematics->out.pose->isometry();
    hysteresis.step(seed, *sample, base_T_target, base_T_sensor, started, ended);
    threshold.step(seed, *sample, base_T_target, base_T_sensor, started, ended);
    in_true = truth.in_contact;
  }
  run.paths += (*sim)->pathsStarted();
  run.abandoned += (*sim)->pathsAbandoned();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size() - 1)))];
}

/// The run over five seeds (CDFF_HAPTIC_PATHS paths each, default 20), once for both tests.
const PathsRun& pathsRun() {
  static PathsRun r;
  static bool ran = false;
  if (ran) return r;
  ran = true;
  const char* env = std::getenv("CDFF_HAPTIC_PATHS");
  const int paths = env ? std::max(1, std::atoi(env)) : 20;
  for (std::uint64_t seed : {1, 2, 3, 4, 5}) {
    const int before = r.paths;
    runSeed(seed, paths, r);
    if (r.paths == before) return r;  // the seed stopped on a failure (reported)
  }
  r.complete = true;
  std::printf(
      "haptic goals: %d paths started, %d abandoned by the servo; %d contacts started "
      "off an approach\n",
      r.paths, r.abandoned, r.off_approach);
  for (const auto& [name, tally] :
       {std::pair<const char*, const Tally&>{"HysteresisLineOfAction", r.hysteresis},
        {"ForceThreshold", r.threshold}}) {
    std::printf(
        "haptic goals, %s: %d true contacts, %d detected, %d with an estimate; %d detections, "
        "%d false; point error p50 %.3f p95 %.3f max %.3f mm; normal error p50 %.2f p95 %.2f "
        "max %.2f deg (the true force's tilt from the normal there p50 %.2f p95 %.2f max %.2f "
        "deg); %d faults\n",
        name, tally.true_contacts, tally.detected, tally.estimated, tally.detections,
        tally.false_detections, 1e3 * percentile(tally.point_errors, 0.5),
        1e3 * percentile(tally.point_errors, 0.95), 1e3 * percentile(tally.point_errors, 1.0),
        percentile(tally.normal_errors, 0.5) / kDeg, percentile(tally.normal_errors, 0.95) / kDeg,
        percentile(tally.normal_errors, 1.0) / kDeg, percentile(tally.friction_tilts, 0.5) / kDeg,
        percentile(tally.friction_tilts, 0.95) / kDeg, percentile(tally.friction_tilts, 1.0) / kDeg,
        tally.faults);
    std::printf(
        "haptic goals, %s, every estimate in contact: %zu, normal error p50 %.2f p95 %.2f max "
        "%.2f deg (friction's tilt p50 %.2f p95 %.2f max %.2f deg)\n",
        name, tally.sample_normal_errors.size(), percentile(tally.sample_normal_errors, 0.5) / kDeg,
        percentile(tally.sample_normal_errors, 0.95) / kDeg,
        percentile(tally.sample_normal_errors, 1.0) / kDeg,
        percentile(tally.sample_tilts, 0.5) / kDeg, percentile(tally.sample_tilts, 0.95) / kDeg,
        percentile(tally.sample_tilts, 1.0) / kDeg);
  }
  return r;
}

TEST(ContactGoals, DetectedLocatedAndOrientedOverRandomCollisionPaths) {
  const PathsRun& r = pathsRun();
  ASSERT_TRUE(r.complete);
  const Tally& tally = r.hysteresis;
  // Every path touches, but those the servo abandons (at most 2 %: a singularity met on the way
  // in spite of the planner's checks); the five running at the end may not have yet.
  EXPECT_LE(r.abandoned, 0.02 * r.paths);
  ASSERT_GE(tally.true_contacts, 0.98 * r.paths - 5);
  EXPECT_EQ(r.off_approach, 0);
  // The paths press to 10 N, a sixth of the sensor's range: no sample saturates.
  EXPECT_EQ(tally.faults, 0);
  EXPECT_GE(tally.detected, 0.99 * tally.true_contacts);
  EXPECT_GE(tally.estimated, 0.99 * tally.true_contacts);
  EXPECT_LE(tally.false_detections, 0.001 * tally.detections);
  // Every contact within the goals: 1 mm, 3 deg.
  EXPECT_LE(percentile(tally.point_errors, 1.0), 1e-3);
  EXPECT_LE(percentile(tally.normal_errors, 1.0), 3 * kDeg);
}

TEST(ContactGoals, ForceThresholdOf2019TakesFrictionIntoItsNormal) {
  const PathsRun& r = pathsRun();
  ASSERT_TRUE(r.complete);
  const Tally& tally = r.threshold;
  const Tally& hysteresis = r.hysteresis;
  ASSERT_GE(tally.true_contacts, 0.98 * r.paths - 5);
  EXPECT_EQ(tally.faults, 0);
  // Its threshold (2 N) is a fifth of the presses' 10 N and above the bias: every contact is
  // found, and nothing else (the force does not hover at the threshold).
  EXPECT_GE(tally.detected, 0.99 * tally.true_contacts);
  EXPECT_GE(tally.estimated, 0.99 * tally.true_contacts);
  EXPECT_LE(tally.false_detections, 0.001 * tally.detections);
  // The paths slide the tip on the surface while the force rises: some samples carry the full
  // Coulomb friction, atan(0.3) = 16.7 deg off the normal (the simulator's, seen by both DFIs).
  const double friction_angle = std::atan(egse::ArmSpec{}.contact.friction);
  EXPECT_NEAR(percentile(tally.sample_tilts, 1.0), friction_angle, 0.1 * kDeg);
  // The force taken for the normal: over the samples in contact its error's p95 is the friction
  // angle's order, half of it at least above HysteresisLineOfAction's (16.1-18.6 deg against
  // 1.5 deg over 100-1050 paths); the bias it leaves in (0.5 N per axis) puts a contact's last
  // estimate, at 10 N without sliding, past the 3 deg goal at the median (5.4 deg).
  EXPECT_GE(percentile(tally.sample_normal_errors, 0.95),
            percentile(hysteresis.sample_normal_errors, 0.95) + 0.5 * friction_angle);
  EXPECT_GT(percentile(tally.normal_errors, 0.5), 3 * kDeg);
  // Regression bounds near today's figures (100 and 1050 paths): per sample p95 18.6 deg; last
  // estimates' normal p95 8.0 deg, point p95 1.39 mm.
  EXPECT_LE(percentile(tally.sample_normal_errors, 0.95), 21 * kDeg);
  EXPECT_LE(percentile(tally.normal_errors, 0.95), 9 * kDeg);
  EXPECT_LE(percentile(tally.point_errors, 0.95), 1.6e-3);
}

}  // namespace
}  // namespace cdff::dfn
