// Registration3D: a VLP-16-like scan (3 cm range noise, ray-cast so only the faces towards the
// sensor are seen) of a satellite-like target is registered against a dense point model sampled
// from the same mesh. Both DFIs must recover the true pose from a tracking-sized error of the
// guess within the accuracy targets (close range: 1 cm and 0.5 deg; mid range: 0.5 % of
// the range and 1 deg), FastIcp also from the initialisation-sized error (10 % of the range and
// 10 deg); the reported covariance must describe the actual errors; bad inputs must be reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

#include "Registration3D.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/statistics.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;

const PointCloud& satelliteModel() {
  static const PointCloud model = [] {
    Result<PointCloud> cloud = sampleSurface(testing::satelliteMesh(), 100'000, 7);
    EXPECT_TRUE(cloud.isOk()) << cloud.status().toString();
    return std::move(cloud).value();
  }();
  return model;
}

// The target seen from a sensor at `range` m along the sensor's x axis, turned so that three
// faces and a wing are in view.
Eigen::Isometry3d lidarTTarget(double range) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(range, 0.1 * range, 0.05 * range);
  return pose;
}

PointCloud scanAt(const Eigen::Isometry3d& truth, std::uint32_t seed) {
  return testing::simulateScan(testing::satelliteMesh(), truth, {}, seed);
}

Transform guessOf(const Eigen::Isometry3d& pose) {
  return Transform::fromIsometry(pose, "lidar", "target");
}

template <typename Dfi>
class Registration3DTest : public ::testing::Test {
 public:
  static std::unique_ptr<Registration3D> make(const std::string& yaml = "{}") {
    return testing::makeDfn<Registration3D>("Registration3D", Dfi::name, yaml);
  }
};

struct FastIcpName {
  static constexpr const char* name = "FastIcp";
};
struct PclName {
  static constexpr const char* name = "PclIcpPointToPlane";
};
using Dfis = ::testing::Types<FastIcpName, PclName>;
TYPED_TEST_SUITE(Registration3DTest, Dfis);

struct Case {
  double range;         // m
  double max_position;  // m, the accuracy requirement at this range
  double max_angle;     // rad
};

TYPED_TEST(Registration3DTest, RecoversThePoseFromATrackingSizedGuessError) {
  // Close range (2 m): 1 cm, 0.5 deg. Mid range (8 m): 0.5 % of the range, 1 deg.
  for (const Case& c : {Case{2.0, 0.01, 0.5 * kDeg}, Case{8.0, 0.005 * 8.0, 1.0 * kDeg}}) {
    auto icp =
        this->make("{max_correspondence_distance: 0.3, inlier_distance: 0.1, max_iterations: 50}");
    for (std::uint32_t seed = 1; seed <= 3; ++seed) {
      const Eigen::Isometry3d truth = lidarTTarget(c.range);
      const PointCloud scan = scanAt(truth, seed);
      ASSERT_GT(scan.size(), 100u);
      icp->in.source.set(scan);
      icp->in.model.set(satelliteModel());
      icp->in.initial_guess.set(guessOf(testing::perturb(truth, 0.05, 2.0 * kDeg, seed)));
      ASSERT_OK(icp->process());
      const testing::PoseError e = testing::poseError(icp->out.transform->isometry(), truth);
      EXPECT_LT(e.translation, c.max_position) << "range " << c.range << " seed " << seed;
      EXPECT_LT(e.rotation, c.max_angle) << "range " << c.range << " seed " << seed;
      EXPECT_TRUE(*icp->out.converged) << "range " << c.range << " seed " << seed << ": "
                                       << *icp->out.iterations << " iterations";
      EXPECT_GT(*icp->out.fitness, 0.95);
      // The residuals are the range noise seen along the normals: at most its 3 cm.
      EXPECT_LT(*icp->out.inlier_rms, 0.035);
      EXPECT_GT(*icp->out.inlier_rms, 0.01);
      EXPECT_EQ(icp->out.transform->parent_frame, "lidar");
      EXPECT_EQ(icp->out.transform->child_frame, "target");
      EXPECT_EQ(icp->out.pose->pose.translation, icp->out.transform->translation);
    }
  }
}

TYPED_TEST(Registration3DTest, ANewModelBufferIsUsedNotTheCachedOne) {
  auto icp = this->make("{max_correspondence_distance: 0.3}");
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  const PointCloud scan = scanAt(truth, 11);
  icp->in.source.set(scan);
  icp->in.model.set(satelliteModel());
  icp->in.initial_guess.set(guessOf(truth));
  ASSERT_OK(icp->process());
  EXPECT_LT(testing::poseError(icp->out.transform->isometry(), truth).translation, 0.01);

  // The same model shifted by 10 cm along its x axis: the pose found must follow.
  std::vector<Point4f> shifted(satelliteModel().points.begin(), satelliteModel().points.end());
  for (Point4f& p : shifted) p.x += 0.1f;
  PointCloud moved = satelliteModel();
  moved.points = Buffer<Point4f>::fromVector(std::move(shifted));
  icp->in.model.set(moved);
  icp->in.source.set(scan);
  icp->in.initial_guess.set(guessOf(truth));
  ASSERT_OK(icp->process());
  const Eigen::Isometry3d expected = truth * Eigen::Translation3d(-0.1, 0, 0);
  EXPECT_LT(testing::poseError(icp->out.transform->isometry(), expected).translation, 0.01);
}

TYPED_TEST(Registration3DTest, ACallWithoutAScanPreparesTheModelAndChangesNoOutput) {
  // A DFPC passes the model before the first scan: that call builds the search structures and
  // publishes nothing; the next call registers the scan. A repeated call without a new scan
  // does not register the old one again.
  auto icp = this->make("{max_correspondence_distance: 0.3}");
  icp->in.model.set(satelliteModel());
  ASSERT_OK(icp->process());
  for (const dfn::OutputPortBase* out : icp->outputs())
    EXPECT_FALSE(out->hasValue()) << "output '" << out->name() << "' set without a scan";

  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  icp->in.source.set(scanAt(truth, 11));
  icp->in.initial_guess.set(guessOf(truth));
  ASSERT_OK(icp->process());
  ASSERT_TRUE(icp->out.transform.hasValue());
  EXPECT_LT(testing::poseError(icp->out.transform->isometry(), truth).translation, 0.01);

  const void* registered = icp->out.transform.anyValue().raw();
  icp->in.model.set(satelliteModel());
  icp->in.initial_guess.set(guessOf(truth));
  ASSERT_OK(icp->process());
  EXPECT_EQ(icp->out.transform.anyValue().raw(), registered);

  // A bad model is still reported without a scan.
  PointCloud bare = satelliteModel();
  bare.normals = {};
  icp->in.model.set(bare);
  testing::expectRejected(*icp, "has no normals");
}

TYPED_TEST(Registration3DTest, NoOverlapIsReportedAsNotConvergedAndKeepsTheGuess) {
  auto icp = this->make("{max_correspondence_distance: 0.3}");
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  icp->in.source.set(scanAt(truth, 3));
  icp->in.model.set(satelliteModel());
  // The guess puts the model 20 m away from where the scan saw it.
  Eigen::Isometry3d far = truth;
  far.translation() += Eigen::Vector3d(20, 0, 0);
  icp->in.initial_guess.set(guessOf(far));
  ASSERT_OK(icp->process());
  EXPECT_FALSE(*icp->out.converged);
  EXPECT_EQ(*icp->out.fitness, 0.0);
  EXPECT_TRUE(std::isnan(*icp->out.inlier_rms));
  EXPECT_LT(testing::poseError(icp->out.transform->isometry(), far).translation, 1e-6);
  EXPECT_GE(icp->diagnostics().warning_count, 1u);
}

TYPED_TEST(Registration3DTest, BadInputsAreReported) {
  auto icp = this->make();
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  const PointCloud scan = scanAt(truth, 5);

  icp->in.source.set(PointCloud{});
  icp->in.model.set(satelliteModel());
  testing::expectRejected(*icp, "input 'source' has no points");

  std::vector<Point4f> with_nan(scan.points.begin(), scan.points.end());
  with_nan[7].y = std::nanf("");
  PointCloud nan_scan = scan;
  nan_scan.points = Buffer<Point4f>::fromVector(std::move(with_nan));
  icp->in.source.set(nan_scan);
  testing::expectRejected(*icp, "input 'source' point 7");

  icp->in.source.set(scan);
  PointCloud bare = satelliteModel();
  bare.normals = {};
  icp->in.model.set(bare);
  testing::expectRejected(*icp, "has no normals");

  std::vector<Point4f> bad_normals(satelliteModel().normals.begin(),
                                   satelliteModel().normals.end());
  bad_normals[3] = Point4f(0, 0, 0);
  PointCloud zero_normal = satelliteModel();
  zero_normal.normals = Buffer<Point4f>::fromVector(std::move(bad_normals));
  icp->in.model.set(zero_normal);
  testing::expectRejected(*icp, "normal 3");

  icp->in.model.set(PointCloud{});
  testing::expectRejected(*icp, "input 'model' has no points");

  icp->in.model.set(satelliteModel());
  Transform nan_guess = guessOf(truth);
  nan_guess.translation.z() = std::nan("");
  icp->in.source.set(scan);
  icp->in.initial_guess.set(nan_guess);
  testing::expectRejected(*icp, "initial_guess");

  Transform wrong = guessOf(truth);
  wrong.parent_frame = "camera";
  icp->in.source.set(scan);
  icp->in.initial_guess.set(wrong);
  testing::expectRejected(*icp, "expected source_T_model = lidar_T_target");

  // The description of another LIDAR than the one that took the scan, an invalid one.
  icp->in.source.set(scan);
  icp->in.initial_guess.set(guessOf(truth));
  icp->in.sensor.set(testing::lidarInfo({}, "velodyne"));
  testing::expectRejected(*icp,
                          "input 'sensor' describes the LIDAR of frame 'velodyne' but input "
                          "'source' is in frame 'lidar'; expected the description of the sensor "
                          "that took the scan");
  LidarInfo invalid = testing::lidarInfo({});
  invalid.elevations[4] = 2.0;
  icp->in.source.set(scan);
  icp->in.sensor.set(invalid);
  testing::expectRejected(*icp, "input 'sensor': LIDAR info 'lidar' laser 4 elevation is 2 rad");

  // Still works afterwards.
  icp->in.source.set(scan);
  icp->in.initial_guess.set(guessOf(truth));
  icp->in.sensor.set(testing::lidarInfo({}));
  ASSERT_OK(icp->process());
  EXPECT_TRUE(*icp->out.converged);
}

TYPED_TEST(Registration3DTest, BadParametersAreRejected) {
  auto node = Registry::instance().create("Registration3D", TypeParam::name);
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{max_correspondence_distance: -1}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("max_correspondence_distance"), std::string::npos) << s.message();
  s = node.value()->configure(YAML::Load("{max_iterations: 0}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

std::unique_ptr<Registration3D> makePcl(const std::string& yaml) {
  return testing::makeDfn<Registration3D>("Registration3D", "PclIcpPointToPlane", yaml);
}

TEST(Registration3DPclIcpPointToPlane, WithItsRejectorsRecoversThePoseFromATrackingSizedGuess) {
  // PCL's ICP as configured for scan-to-model tracking (the benchmark's peer): back faces and
  // pairs beyond three robust standard deviations of the pair distances rejected. The same
  // scans, guesses and accuracy targets as RecoversThePoseFromATrackingSizedGuessError.
  for (const Case& c : {Case{2.0, 0.01, 0.5 * kDeg}, Case{8.0, 0.005 * 8.0, 1.0 * kDeg}}) {
    auto icp = makePcl(
        "{max_correspondence_distance: 0.3, inlier_distance: 0.1, max_iterations: 50, "
        "back_face_rejection: true, median_rejection_factor: 4.45}");
    for (std::uint32_t seed = 1; seed <= 3; ++seed) {
      const Eigen::Isometry3d truth = lidarTTarget(c.range);
      icp->in.source.set(scanAt(truth, seed));
      icp->in.model.set(satelliteModel());
      icp->in.initial_guess.set(guessOf(testing::perturb(truth, 0.05, 2.0 * kDeg, seed)));
      ASSERT_OK(icp->process());
      const testing::PoseError e = testing::poseError(icp->out.transform->isometry(), truth);
      EXPECT_LT(e.translation, c.max_position) << "range " << c.range << " seed " << seed;
      EXPECT_LT(e.rotation, c.max_angle) << "range " << c.range << " seed " << seed;
      EXPECT_TRUE(*icp->out.converged) << "range " << c.range << " seed " << seed;
      EXPECT_GT(*icp->out.fitness, 0.95);
    }
  }
}

TEST(Registration3DPclIcpPointToPlane, TheRejectorsActOnTheCorrespondences) {
  // A median factor of 1e-6 keeps no pair: PCL finds too few correspondences, the call reports
  // it and keeps the guess. Back-face rejection alone, from the sensor's viewpoint, converges.
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  const Transform guess = guessOf(testing::perturb(truth, 0.05, 2.0 * kDeg, 5));
  const auto run = [&](const std::string& rejectors) {
    auto icp = makePcl("{max_correspondence_distance: 0.3, max_iterations: 50, " + rejectors + "}");
    icp->in.source.set(scanAt(truth, 5));
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guess);
    EXPECT_OK(icp->process());
    return icp;
  };
  auto none = run("median_rejection_factor: 1.0e-6");
  EXPECT_FALSE(*none->out.converged);
  EXPECT_EQ(none->out.transform->translation, guess.translation);
  ASSERT_FALSE(none->diagnostics().warnings.empty());
  auto right = run("back_face_rejection: true");
  EXPECT_TRUE(*right->out.converged);
  EXPECT_LT(testing::poseError(right->out.transform->isometry(), truth).translation, 0.02);
}

std::unique_ptr<Registration3D> makeFast(const std::string& yaml = "{}") {
  return testing::makeDfn<Registration3D>("Registration3D", "FastIcp", yaml);
}

TEST(Registration3DFastIcp, ConvergesFromAnInitialisationSizedGuessError) {
  // The detection stand-in of the issue: 10 % of the range and 10 deg off. The correspondence
  // distance starts wide (point-to-point first) and shrinks as the alignment improves. From so
  // far off a sparse scan can mislead any ICP into another minimum: at least 11 of these 12
  // must recover (the DFPC re-initialises when one does not; its tracking rate is measured
  // end to end).
  int recovered = 0, runs = 0;
  std::string failures;
  for (const double range : {3.0, 6.0, 10.0}) {
    auto icp = makeFast(
        fmt::format("{{max_correspondence_distance: {}, max_iterations: 100}}", 0.2 * range + 0.5));
    for (std::uint32_t seed = 1; seed <= 4; ++seed) {
      const Eigen::Isometry3d truth = lidarTTarget(range);
      icp->in.source.set(scanAt(truth, seed));
      icp->in.model.set(satelliteModel());
      icp->in.initial_guess.set(
          guessOf(testing::perturb(truth, 0.1 * range, 10.0 * kDeg, 100 + seed)));
      ASSERT_OK(icp->process());
      const testing::PoseError e = testing::poseError(icp->out.transform->isometry(), truth);
      ++runs;
      if (e.translation < 0.005 * range && e.rotation < 1.0 * kDeg && *icp->out.converged)
        ++recovered;
      else
        failures += fmt::format(" [range {} seed {}: {:.3f} m, {:.1f} deg]", range, seed,
                                e.translation, e.rotation / kDeg);
    }
  }
  RecordProperty("recovered", fmt::format("{}/{}", recovered, runs));
  EXPECT_GE(recovered, runs - 1) << "not recovered:" << failures;
}

TEST(Registration3DFastIcp, TheCovarianceDescribesTheSpreadAndTheBiasIsSmall) {
  // Monte Carlo over the scan noise at a fixed pose (4 m). The Gauss-Newton covariance treats
  // residuals as independent and correspondences as right; with the default inflation (1.5) it
  // must describe the estimates' spread about their mean (the NEES of the de-biased errors
  // within the chi-square 99 % interval). The mean error itself is a bias the covariance cannot
  // know of: correspondences near edges, where the range noise moves a point closer to the
  // neighbouring face, pull one way; the lookup grid's nearest-to-the-cell-centre matches add about
  // half a millimetre near edges. It must stay well below the accuracy targets at this range (2 cm
  // and 1 deg; 3 mm and 0.3 deg here); the DFPC accounts for it with covariance_inflation (the
  // recorded ANEES of the raw errors says by how much).
  constexpr int kRuns = 40;
  auto icp = makeFast(
      "{max_correspondence_distance: 0.3, translation_epsilon: 1.0e-6, "
      "rotation_epsilon: 5.729577951308232e-5, max_iterations: 100}");
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  std::vector<Vector6d> errors;
  std::vector<Matrix6d> covariances;
  Vector6d mean = Vector6d::Zero();
  for (int run = 0; run < kRuns; ++run) {
    icp->in.source.set(scanAt(truth, 1000 + run));
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guessOf(testing::perturb(truth, 0.03, 1.0 * kDeg, run)));
    ASSERT_OK(icp->process());
    const PoseWithCovariance& z = *icp->out.pose;
    Vector6d e;
    e.head<3>() = z.pose.translation - truth.translation();
    e.tail<3>() = logSO3(z.pose.rotation * Eigen::Quaterniond(truth.linear()).conjugate());
    errors.push_back(e);
    covariances.push_back(z.covariance);
    mean += e / kRuns;
  }
  double sum_spread = 0, sum_raw = 0;
  for (int run = 0; run < kRuns; ++run) {
    const Vector6d d = errors[run] - mean;
    sum_spread += d.dot(covariances[run].ldlt().solve(d));
    sum_raw += errors[run].dot(covariances[run].ldlt().solve(errors[run]));
  }
  // Removing the sample mean takes 6 of the 6 kRuns degrees of freedom.
  const double spread_anees = sum_spread / kRuns;
  const double low = chiSquareQuantile(0.005, 6 * (kRuns - 1)) / kRuns;
  const double high = chiSquareQuantile(0.995, 6 * (kRuns - 1)) / kRuns;
  RecordProperty("spread_anees_6dof",
                 fmt::format("{:.2f} in [{:.2f}, {:.2f}]", spread_anees, low, high));
  RecordProperty("raw_anees_6dof", fmt::format("{:.2f}", sum_raw / kRuns));
  RecordProperty("bias", fmt::format("{:.2f} mm, {:.3f} deg", 1e3 * mean.head<3>().norm(),
                                     mean.tail<3>().norm() / kDeg));
  EXPECT_GT(spread_anees, low) << "the covariance is pessimistic";
  EXPECT_LT(spread_anees, high) << "the covariance is overconfident about the spread";
  EXPECT_LT(mean.head<3>().norm(), 0.003);
  EXPECT_LT(mean.tail<3>().norm(), 0.3 * kDeg);
}

TEST(Registration3DFastIcp, ExactRefinementRemovesTheLookupGridsBias) {
  // The lookup grid returns the model point nearest to a cell's centre, which near the model's
  // edges can lie on the neighbouring face; a few iterations with exact nearest points after
  // the grid has converged end where the exact (KD-tree only) registration ends. Close range,
  // tracking-sized guess errors (5 cm, 2 deg), as in the LIDAR tracking DFPC.
  auto grid = makeFast("{max_correspondence_distance: 0.3}");
  auto refined = makeFast("{max_correspondence_distance: 0.3, exact_refinement_iterations: 5}");
  auto exact = makeFast("{max_correspondence_distance: 0.3, lookup_grid_cell: 0}");
  double grid_angle = 0, refined_angle = 0, worst_gap_m = 0, worst_gap_rad = 0;
  constexpr int kRuns = 8;
  for (std::uint32_t seed = 1; seed <= kRuns; ++seed) {
    const Eigen::Isometry3d truth = lidarTTarget(2.5);
    const PointCloud scan = scanAt(truth, seed);
    const Transform guess = guessOf(testing::perturb(truth, 0.05, 2.0 * kDeg, 200 + seed));
    Eigen::Isometry3d result[3];
    Registration3D* nodes[3] = {grid.get(), refined.get(), exact.get()};
    for (int k = 0; k < 3; ++k) {
      nodes[k]->in.source.set(scan);
      nodes[k]->in.model.set(satelliteModel());
      nodes[k]->in.initial_guess.set(guess);
      ASSERT_OK(nodes[k]->process());
      EXPECT_TRUE(*nodes[k]->out.converged) << "seed " << seed << " node " << k;
      result[k] = nodes[k]->out.transform->isometry();
    }
    grid_angle += testing::poseError(result[0], truth).rotation / kRuns;
    refined_angle += testing::poseError(result[1], truth).rotation / kRuns;
    const testing::PoseError gap = testing::poseError(result[1], result[2]);
    worst_gap_m = std::max(worst_gap_m, gap.translation);
    worst_gap_rad = std::max(worst_gap_rad, gap.rotation);
  }
  RecordProperty("grid_mean_angle_deg", fmt::format("{:.4f}", grid_angle / kDeg));
  RecordProperty("refined_mean_angle_deg", fmt::format("{:.4f}", refined_angle / kDeg));
  RecordProperty("refined_vs_exact_worst",
                 fmt::format("{:.5f} m, {:.4f} deg", worst_gap_m, worst_gap_rad / kDeg));
  std::printf(
      "mean angle error: grid %.4f deg, refined %.4f deg; refined vs exact: %.5f m, %.4f deg\n",
      grid_angle / kDeg, refined_angle / kDeg, worst_gap_m, worst_gap_rad / kDeg);
  EXPECT_LE(refined_angle, grid_angle);
  // Within a tenth of the close-range requirement (1 cm, 0.5 deg) of the exact registration.
  EXPECT_LT(worst_gap_m, 1e-3);
  EXPECT_LT(worst_gap_rad, 0.05 * kDeg);
}

TEST(Registration3DFastIcp, AKernelFlooredAtTheSensorNoiseTracksFromAFewDegreesOff) {
  // A sparse VLP-16-like scan at 15 m (3 cm range noise) registered, as the LIDAR tracking DFPC's
  // `icp` registers it, from a prediction a few degrees off (an acquisition's error). A kernel
  // scale below the sensor's noise down-weights the returns far from the target's centre, whose
  // residuals the turn makes largest and which alone measure the attitude, and stops short of
  // the truth; floored at the noise (kernel_floor_at_sensor_noise, `sensor`'s range_noise) it
  // uses them. Over 12 scans and guesses the floored kernel's mean angle error must be below the
  // plain floor's (0.71 deg on 2026-12-04) and within 1.4 times today's 0.59 deg (the mid-range
  // goal is 1 deg).
  const char* tracking =
      "{max_correspondence_distance: 3.0, min_correspondence_distance: 0.05, "
      "max_iterations: 50, exact_refinement_iterations: 3";
  auto plain = makeFast(std::string(tracking) + "}");
  auto floored = makeFast(std::string(tracking) + ", kernel_floor_at_sensor_noise: true}");
  const LidarInfo sensor = testing::lidarInfo({});
  ASSERT_GT(sensor.range_noise, 0.0);
  plain->in.sensor.set(sensor);
  floored->in.sensor.set(sensor);
  constexpr int kRuns = 12;
  double plain_deg = 0, floored_deg = 0, floored_worst_deg = 0;
  for (std::uint32_t seed = 1; seed <= kRuns; ++seed) {
    const Eigen::Isometry3d truth = lidarTTarget(15.0);
    const PointCloud scan = scanAt(truth, 300 + seed);
    const Transform guess = guessOf(testing::perturb(truth, 0.02, 3.0 * kDeg, 400 + seed));
    double error_deg[2];
    Registration3D* nodes[2] = {plain.get(), floored.get()};
    for (int k = 0; k < 2; ++k) {
      nodes[k]->in.source.set(scan);
      nodes[k]->in.model.set(satelliteModel());
      nodes[k]->in.initial_guess.set(guess);
      ASSERT_OK(nodes[k]->process());
      error_deg[k] = testing::poseError(nodes[k]->out.transform->isometry(), truth).rotation / kDeg;
    }
    plain_deg += error_deg[0] / kRuns;
    floored_deg += error_deg[1] / kRuns;
    floored_worst_deg = std::max(floored_worst_deg, error_deg[1]);
  }
  std::printf(
      "mean angle error from 3 deg off at 15 m: plain %.3f deg, floored %.3f deg (worst %.3f)\n",
      plain_deg, floored_deg, floored_worst_deg);
  RecordProperty("mean_angle_error_deg",
                 fmt::format("plain {:.3f}, floored {:.3f}", plain_deg, floored_deg));
  EXPECT_LT(floored_deg, plain_deg);
  EXPECT_LT(floored_deg, 1.4 * 0.59);
}

TEST(Registration3DFastIcp, VisibilityTellsASlidModelFromTheRightPose) {
  // A VLP-16-like scan at 12 m (16 rings 2 degrees apart). At the true pose nearly every bit of
  // model surface on the scan's rings has a return; the model slid by 0.6 m across the line of
  // sight or along it, or turned by 15 degrees, puts surface where the lasers saw nothing. The pose
  // is held where it is given (no correspondence within reach: the guess is returned) so that the
  // visibility is that of the given pose.
  const char* yaml =
      "{max_correspondence_distance: 1.0e-6, min_correspondence_distance: 1.0e-6, "
      "visibility_check: true}";
  auto icp = makeFast(yaml);
  icp->in.sensor.set(testing::lidarInfo({}));
  const Eigen::Isometry3d truth = lidarTTarget(12.0);
  const PointCloud scan = scanAt(truth, 3);
  auto visibilityAt = [&](const Eigen::Isometry3d& pose) {
    icp->in.source.set(scan);
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guessOf(pose));
    EXPECT_OK(icp->process());
    return *icp->out.visibility;
  };
  const double right = visibilityAt(truth);
  Eigen::Isometry3d slid = truth;
  slid.translation() += Eigen::Vector3d(0, 0.6, 0);
  Eigen::Isometry3d lifted = truth;
  lifted.translation() += Eigen::Vector3d(0, 0, 0.6);
  Eigen::Isometry3d turned = truth;
  turned.linear() =
      Eigen::AngleAxisd(15 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix() * truth.linear();
  const double v_slid = visibilityAt(slid), v_lifted = visibilityAt(lifted),
               v_turned = visibilityAt(turned);
  std::printf("visibility: right %.3f, slid %.3f, lifted %.3f, turned %.3f\n", right, v_slid,
              v_lifted, v_turned);
  EXPECT_GE(right, 0.9);
  EXPECT_LE(v_slid, right - 0.2);
  EXPECT_LE(v_lifted, right - 0.2);
  // A turn about the spin axis moves surface along the rings more than off them (measured
  // 0.85 against 1.0).
  EXPECT_LE(v_turned, right - 0.1);
  // Off unless asked for, and not a PclIcpPointToPlane measure.
  auto plain = makeFast();
  plain->in.source.set(scan);
  plain->in.model.set(satelliteModel());
  plain->in.initial_guess.set(guessOf(truth));
  ASSERT_OK(plain->process());
  EXPECT_TRUE(std::isnan(*plain->out.visibility));
}

TEST(Registration3DFastIcp, VisibilityCountsTheSensorsEmptyRingsWhateverTheirSpacing) {
  // A LIDAR whose lasers are unevenly spaced (denser near the horizon) and listed in firing
  // order, at 12 m: the target's returns lie on some of its lasers; the lasers just below and
  // above those saw nothing of the target. A pose that moves model surface onto them is
  // contradicted by them, which only the sensor's description tells: without it the visibility
  // counts the rings with returns only. The right pose has a return nearly wherever it puts
  // visible surface either way.
  testing::ScanOptions options;
  for (const double deg : {-15.0, 3.0, -7.0, 5.5, -3.0, 8.5, -1.0, 12.0, 1.0, 15.0})
    options.elevations.push_back(deg * kDeg);
  const LidarInfo sensor = testing::lidarInfo(options);
  const Eigen::Isometry3d truth = lidarTTarget(12.0);
  const PointCloud scan = testing::simulateScan(testing::satelliteMesh(), truth, options, 3);
  std::set<std::uint16_t> seen(scan.ring.begin(), scan.ring.end());
  // Lasers with returns, lowest first, and their neighbours without.
  std::vector<double> observed;
  for (const std::uint16_t ring : seen) observed.push_back(options.elevations[ring]);
  std::sort(observed.begin(), observed.end());
  std::printf("observed lasers: %zu, from %.1f to %.1f deg\n", observed.size(),
              observed.front() / kDeg, observed.back() / kDeg);
  ASSERT_GE(observed.size(), 2u);
  ASSERT_GT(observed.front(), -15.0 * kDeg) << "a laser below the returns saw nothing";
  ASSERT_LT(observed.back(), 15.0 * kDeg) << "a laser above the returns saw nothing";

  auto icp = makeFast(
      "{max_correspondence_distance: 1.0e-6, min_correspondence_distance: 1.0e-6, "
      "visibility_check: true}");
  auto visibility = [&](const Eigen::Isometry3d& pose, const LidarInfo* description) {
    if (description != nullptr)
      icp->in.sensor.set(*description);
    else
      icp->in.sensor.clear();
    icp->in.source.set(scan);
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guessOf(pose));
    EXPECT_OK(icp->process());
    return *icp->out.visibility;
  };
  Eigen::Isometry3d lifted = truth, lowered = truth;
  lifted.translation().z() += 0.6;
  lowered.translation().z() -= 0.6;
  const double right = visibility(truth, &sensor), right_rings = visibility(truth, nullptr);
  const double up = visibility(lifted, &sensor), up_rings = visibility(lifted, nullptr);
  const double down = visibility(lowered, &sensor), down_rings = visibility(lowered, nullptr);
  std::printf(
      "visibility with the sensor (rings with returns only): right %.3f (%.3f), "
      "lifted %.3f (%.3f), lowered %.3f (%.3f)\n",
      right, right_rings, up, up_rings, down, down_rings);
  EXPECT_GE(right, 0.9);
  EXPECT_GE(right_rings, 0.9);
  EXPECT_LE(up, up_rings - 0.1);
  EXPECT_LE(down, down_rings - 0.1);
  EXPECT_LE(up, right - 0.2);
  EXPECT_LE(down, right - 0.2);
  // The order the lasers are listed in does not matter.
  LidarInfo sorted = sensor;
  std::sort(sorted.elevations.begin(), sorted.elevations.end());
  EXPECT_EQ(visibility(lifted, &sorted), up);
  // A sensor without lasers beyond those with returns adds no ring.
  LidarInfo bare = sensor;
  bare.elevations = observed;
  EXPECT_EQ(visibility(lifted, &bare), up_rings);
  EXPECT_EQ(visibility(lowered, &bare), down_rings);
}

TEST(Registration3DFastIcp, VisibilityOfAVoxelThinnedScanCountsEachReturnOnItsNearestLaser) {
  // The DFPC thins its scans with a voxel grid (centroids). Close to the target a voxel is about
  // as tall as the lasers' spacing there, and a centroid that averages two lasers' returns lies
  // between them; so does a de-skewed return. Grouped by the sensor's lasers, such returns still
  // confirm the right pose (a VLP-16-like scan at 4 m thinned with 16 cm voxels, 2.3 degrees
  // there, the lasers 2 degrees apart, as the DFPC's 3 cm voxels at 0.75 m; grouped by elevation
  // alone: 0.61 on 2026-12-05); the model slid across the line of sight does not.
  const Eigen::Isometry3d truth = lidarTTarget(4.0);
  const PointCloud dense = scanAt(truth, 5);
  constexpr double kVoxel = 0.16;
  std::map<std::array<long, 3>, std::pair<Eigen::Vector3d, int>> voxels;
  for (const Point4f& p : dense.points) {
    const Eigen::Vector3d v = p.vec().cast<double>();
    if (!v.allFinite() || v.norm() > 20.0) continue;  // a laser that saw nothing of the target
    const std::array<long, 3> key = {std::lround(std::floor(v.x() / kVoxel)),
                                     std::lround(std::floor(v.y() / kVoxel)),
                                     std::lround(std::floor(v.z() / kVoxel))};
    auto& [sum, n] = voxels.try_emplace(key, Eigen::Vector3d::Zero(), 0).first->second;
    sum += v;
    ++n;
  }
  std::vector<Eigen::Vector3f> centroids;
  for (const auto& [key, cell] : voxels)
    centroids.push_back((cell.first / cell.second).cast<float>());
  const PointCloud thinned = PointCloud::fromXyz(centroids, dense.frame_id, dense.stamp);
  ASSERT_OK(thinned.validate());
  auto icp = makeFast(
      "{max_correspondence_distance: 1.0e-6, min_correspondence_distance: 1.0e-6, "
      "visibility_check: true}");
  icp->in.sensor.set(testing::lidarInfo({}));
  auto visibilityAt = [&](const Eigen::Isometry3d& pose) {
    icp->in.source.set(thinned);
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guessOf(pose));
    EXPECT_OK(icp->process());
    return *icp->out.visibility;
  };
  Eigen::Isometry3d slid = truth;
  slid.translation() += Eigen::Vector3d(0, 0.3, 0);
  const double right = visibilityAt(truth), v_slid = visibilityAt(slid);
  std::printf("thinned scan (%zu of %zu returns): visibility right %.3f, slid %.3f\n",
              thinned.size(), dense.size(), right, v_slid);
  EXPECT_GE(right, 0.85);
  EXPECT_LE(v_slid, right - 0.2);
}

TEST(Registration3DFastIcp, ConfirmationScoresTheHypothesesOverSeveralScans) {
  // Acquisition from 10 degrees off at 12 m with confirmation_scans 3: the pose is reported
  // ambiguous until three scans are scored, then, the scans being dense enough to single one
  // hypothesis out, not ambiguous and close to the truth; the set is then dropped, so that a
  // later scan starts a new one (ambiguous again). Without confirmation it is never ambiguous.
  const char* yaml =
      "{max_correspondence_distance: 3.0, hypotheses: 24, hypothesis_angle: "
      "10, hypothesis_iterations: 15, visibility_check: true, "
      "confirmation_scans: 3}";
  auto icp = makeFast(yaml);
  icp->in.sensor.set(testing::lidarInfo({}));
  const Eigen::Isometry3d truth = lidarTTarget(12.0);
  const Transform guess = guessOf(testing::perturb(truth, 0.3, 10.0 * kDeg, 31));
  std::vector<bool> ambiguous;
  Eigen::Isometry3d confirmed = Eigen::Isometry3d::Identity();
  for (std::uint32_t k = 0; k < 4; ++k) {
    PointCloud scan = scanAt(truth, 40 + k);
    scan.stamp = fromSeconds(0.1 * k);
    icp->in.source.set(scan);
    icp->in.model.set(satelliteModel());
    icp->in.initial_guess.set(guess);
    ASSERT_OK(icp->process());
    ambiguous.push_back(*icp->out.ambiguous);
    if (k == 2) confirmed = icp->out.transform->isometry();
  }
  EXPECT_TRUE(ambiguous[0]);
  EXPECT_TRUE(ambiguous[1]);
  EXPECT_FALSE(ambiguous[2]);
  EXPECT_TRUE(ambiguous[3]);  // a new set after the decision
  const testing::PoseError error = testing::poseError(confirmed, truth);
  std::printf("confirmed pose: %.4f m, %.3f deg off\n", error.translation, error.rotation / kDeg);
  // The mid-range target (1 % of the range, 1 degree).
  EXPECT_LT(error.translation, 0.12);
  EXPECT_LT(error.rotation, 1.0 * kDeg);
  auto plain = makeFast("{hypotheses: 24}");
  plain->in.source.set(scanAt(truth, 40));
  plain->in.model.set(satelliteModel());
  plain->in.initial_guess.set(guess);
  ASSERT_OK(plain->process());
  EXPECT_FALSE(*plain->out.ambiguous);
}

TEST(Registration3DFastIcp, ConfirmationDecidesAtOnceWhenEveryStartEndsInOneMinimum) {
  // A re-acquisition from a small error (the coasted state, 2 cm and 1 degree off) on a scan
  // that constrains the pose: every start ends in the same minimum, there is no rival for more
  // scans to rule out, so the first scan's pose is not ambiguous (a DFPC fuses it at once
  // instead of coasting two more scans).
  const char* yaml =
      "{max_correspondence_distance: 3.0, hypotheses: 24, hypothesis_angle: "
      "10, hypothesis_iterations: 15, visibility_check: true, "
      "confirmation_scans: 3}";
  auto icp = makeFast(yaml);
  icp->in.sensor.set(testing::lidarInfo({}));
  const Eigen::Isometry3d truth = lidarTTarget(5.0);
  icp->in.source.set(scanAt(truth, 40));
  icp->in.model.set(satelliteModel());
  icp->in.initial_guess.set(guessOf(testing::perturb(truth, 0.02, 1.0 * kDeg, 32)));
  ASSERT_OK(icp->process());
  EXPECT_FALSE(*icp->out.ambiguous);
  const testing::PoseError error = testing::poseError(icp->out.transform->isometry(), truth);
  std::printf("decided pose: %.4f m, %.3f deg off\n", error.translation, error.rotation / kDeg);
  EXPECT_LT(error.translation, 0.01 * 5.0);
  EXPECT_LT(error.rotation, 1.0 * kDeg);
}

TEST(Registration3DFastIcp, ABadGuessUncertaintyIsReported) {
  auto icp = makeFast("{hypotheses: 24}");
  const Eigen::Isometry3d truth = lidarTTarget(5.0);
  const PointCloud scan = scanAt(truth, 41);
  icp->in.model.set(satelliteModel());
  icp->in.initial_guess.set(guessOf(truth));
  RigidBodyState uncertainty;
  uncertainty.pose = guessOf(truth);
  uncertainty.covariance.setIdentity();
  uncertainty.covariance(2, 2) = std::nan("");
  icp->in.source.set(scan);
  icp->in.guess_uncertainty.set(uncertainty);
  testing::expectRejected(*icp, "input 'guess_uncertainty' has a non-finite position covariance");
  uncertainty.covariance.setIdentity();
  uncertainty.pose.parent_frame = "servicer";
  icp->in.source.set(scan);
  icp->in.guess_uncertainty.set(uncertainty);
  testing::expectRejected(*icp,
                          "input 'guess_uncertainty' is expressed in frame 'servicer'; "
                          "expected the source's frame 'lidar'");
  uncertainty.pose.parent_frame = "lidar";
  icp->in.source.set(scan);
  icp->in.guess_uncertainty.set(uncertainty);
  ASSERT_OK(icp->process());
}

}  // namespace
}  // namespace cdff::dfn
