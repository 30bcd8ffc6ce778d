// PoseRefinement/DepthIcp on depth maps of the procedural target ray-cast at known poses, with
// the depth noise the DFI is told (independent per pixel, as a ToF camera's), seen by the
// stereo camera's left image at half resolution.
//
// Tolerances: the detection's goal after refinement is 1 % of the range and 2 degrees; the
// starts are what TemplateDetection gives (within 15 degrees and 10 % of the range) or such a
// pose half-turned about one of the model's three axes (the near-symmetry that template
// matching cannot resolve).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include <fmt/format.h>

#include "PoseRefinement.gen.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/rng.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/opencv.hpp"
#include "depth_fit.hpp"
#include "support/detections.hpp"
#include "support/dfn_testing.hpp"

namespace cdff {
namespace {

using dfn::PoseRefinement;

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kNoiseConstant = 0.005, kNoiseQuadratic = 0.0017;  // the DFI's defaults

CameraModel undistorted(CameraModel m) {
  m.distortion_model = DistortionModel::kNone;
  m.distortion.clear();
  return m;
}

struct Suite {
  egse::TargetModel target;
  std::unique_ptr<egse::RayCaster> caster;
  PointCloud model;
  egse::TofSpec spec;
};

const Suite& suite() {
  static const Suite* s = [] {
    auto* out = new Suite;
    out->target = egse::makeTargetSatellite().value();
    out->caster = egse::RayCaster::create(out->target).value();
    const auto points = static_cast<std::size_t>(out->target.surfaceArea() / (0.02 * 0.02));
    out->model = sampleSurface(out->target.mesh, points, 7).value();
    out->model.frame_id = "target";
    // The stereo camera's rectified left image at half resolution, where StereoMatching gives
    // the detection's depth.
    out->spec.model = cameraAfterPyrDown(undistorted(egse::prosilicaGc1600h()), 1);
    out->spec.max_range = 40;
    out->spec.min_amplitude = 0;
    out->spec.noise_constant = kNoiseConstant;
    out->spec.noise_quadratic = kNoiseQuadratic;
    return out;
  }();
  return *s;
}

/// The truth: the target's bounding centre at `range` on a ray through the middle half of the
/// image, at a random attitude.
Eigen::Isometry3d drawTruth(std::mt19937& rng, double range) {
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() =
      Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
  const Eigen::Vector3d centre = Eigen::Vector3d(u(rng), u(rng), 1).normalized() * range;
  truth.translation() = centre - truth.linear() * suite().target.boundingCentre();
  return truth;
}

DepthMap depthOf(const Eigen::Isometry3d& truth, std::uint64_t seed) {
  const Suite& s = suite();
  egse::TofSensor sensor = egse::TofSensor::create(s.spec, "tof").value();
  egse::Rng rng(seed);
  DepthMap d = sensor.capture(*s.caster, s.target, truth, 0.0, rng).value();
  d.image.frame_id = "camera";
  d.image.stamp = 1000;
  return d;
}

/// `truth` moved by `angle` about a random axis through the bounding centre and by `shift` of
/// the range along a random direction.
Eigen::Isometry3d perturbed(const Eigen::Isometry3d& truth, double angle, double shift,
                            std::mt19937& rng) {
  std::normal_distribution<double> g;
  const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d direction = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d centre = truth * suite().target.boundingCentre();
  Eigen::Isometry3d p = truth;
  p.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * truth.linear();
  p.translation() =
      centre - p.linear() * suite().target.boundingCentre() + direction * shift * centre.norm();
  return p;
}

Detections detectionsAt(const std::vector<Eigen::Isometry3d>& poses) {
  return testing::detectionsAt(poses, 0.8);
}

/// The DFI set for a depth camera that measures wherever the target is (a missing depth is
/// evidence), with `extra` settings.
std::unique_ptr<PoseRefinement> make(const std::string& extra = "") {
  return testing::makeDfn<PoseRefinement>("PoseRefinement", "DepthIcp",
                                          "{missing_depth_cost: 9" + extra + "}");
}

struct Errors {
  double angle_deg, position_fraction;
};

Errors errorsOf(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& truth) {
  const Eigen::Vector3d c = suite().target.boundingCentre();
  return {Eigen::AngleAxisd(pose.linear().transpose() * truth.linear()).angle() / kDeg,
          ((pose * c) - (truth * c)).norm() / (truth * c).norm()};
}

/// Refines `starts` on the depth of `truth`; returns the errors of the output.
Errors refine(PoseRefinement& dfn, const Eigen::Isometry3d& truth,
              const std::vector<Eigen::Isometry3d>& starts, std::uint64_t seed) {
  dfn.in.detections.set(detectionsAt(starts));
  dfn.in.depth.set(depthOf(truth, seed));
  dfn.in.model.set(suite().model);
  const Status s = dfn.process();
  EXPECT_TRUE(s.isOk()) << s.toString();
  EXPECT_TRUE(*dfn.out.refined) << "fitness " << *dfn.out.fitness << ", confirmed "
                                << *dfn.out.confirmed << ", misfit " << *dfn.out.misfit;
  if (!dfn.out.pose.hasValue()) return {1e9, 1e9};
  return errorsOf(dfn.out.pose->pose.isometry(), truth);
}

/// Of `draws` draws at ranges log-uniform over [4, 10] m (where the depth's noise, 3 to 18 cm,
/// still shows the target's asymmetric parts: the adapter ring, the antenna), how many end
/// within the goal (1 % of the range, 2 degrees) from a start that is the truth moved by up to
/// `angle` and `shift` of the range, after a half turn about one of the model's axes (its
/// near-symmetries) when `half_turns`.
struct Outcome {
  int within_goal = 0;
  double mean_nees = 0;  // of the pose covariance, over the draws within the goal
};

double nees(const PoseWithCovariance& estimate, const Eigen::Isometry3d& truth) {
  return eval::poseNees(estimate.pose, Transform::fromIsometry(truth, "", "", 0),
                        estimate.covariance);
}

Outcome withinGoal(int draws, std::uint32_t seed, double angle, double shift, bool half_turns) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  registration::ModelIndex index;
  EXPECT_TRUE(index.update(suite().model).isOk());
  const std::vector<Eigen::Isometry3d> symmetries =
      registration::motionsOf(registration::nearSymmetries(index));
  auto dfn = make();
  Outcome out;
  for (int draw = 0; draw < draws; ++draw) {
    const double range = 4.0 * std::pow(10.0 / 4.0, u(rng));
    const Eigen::Isometry3d truth = drawTruth(rng, range);
    const std::size_t turn = half_turns ? 1 + static_cast<std::size_t>(draw % 3) : 0;
    const Eigen::Isometry3d start = perturbed(pose_refinement::startsOf(truth, symmetries)[turn],
                                              angle * u(rng), shift * u(rng), rng);
    const Errors e = refine(*dfn, truth, {start}, seed * 100 + draw);
    const bool ok = e.angle_deg < 2.0 && e.position_fraction < 0.01;
    out.within_goal += ok;
    if (ok) out.mean_nees += nees(*dfn->out.pose, truth);
    if (!ok)
      std::cout << fmt::format("draw {} at {:.1f} m: {:.2f} deg, {:.2f} % of the range\n", draw,
                               range, e.angle_deg, 100 * e.position_fraction);
  }
  if (out.within_goal > 0) out.mean_nees /= out.within_goal;
  return out;
}

TEST(PoseRefinementDepthIcp, RefinesCoarseDetectionsToTheGoal) {
  // Starts as far off as a correct detection may be: 15 degrees and 10 % of the range.
  const Outcome o = withinGoal(16, 21, 15 * kDeg, 0.10, false);
  EXPECT_GE(o.within_goal, 15);
  // An honest covariance: the mean NEES (6 degrees of freedom) within a factor 2 of 6.
  EXPECT_GE(o.mean_nees, 3.0);
  EXPECT_LE(o.mean_nees, 12.0);
}

TEST(PoseRefinementDepthIcp, TellsAHalfTurnedDetectionFromTheRightOne) {
  EXPECT_GE(withinGoal(12, 22, 8 * kDeg, 0.03, true).within_goal, 11);
}

TEST(PoseRefinementDepthIcp, ChoosesTheRightCandidateAmongWrongOnes) {
  std::mt19937 rng(13);
  auto dfn = make(", symmetry_starts: false");
  const Eigen::Isometry3d truth = drawTruth(rng, 8.0);
  const std::vector<Eigen::Isometry3d> starts = {perturbed(truth, 60 * kDeg, 0.05, rng),
                                                 perturbed(truth, 90 * kDeg, 0.05, rng),
                                                 perturbed(truth, 10 * kDeg, 0.03, rng)};
  const Errors e = refine(*dfn, truth, starts, 300);
  EXPECT_EQ(*dfn->out.candidate, 2);
  EXPECT_LT(e.angle_deg, 2.0);
  EXPECT_LT(e.position_fraction, 0.01);
  // The finalists for a second stage: the chosen pose first, then the others, each distinct.
  const Detections& finalists = *dfn->out.candidates;
  ASSERT_EQ(finalists.detections.size(), 3u);  // `finalists` (3) of the three starts
  EXPECT_EQ(finalists.frame_id, dfn->out.pose->pose.parent_frame);
  EXPECT_LT(angularDistance(finalists.detections[0].pose.rotation, dfn->out.pose->pose.rotation),
            1e-9);
  EXPECT_TRUE(finalists.validate().isOk());
  for (const Detection& d : finalists.detections) EXPECT_GE(d.similarity, 0.0);
}

// rival_margin: the misfit of the best pose that is another attitude (a half turn), less the
// best's; a pose without one has an infinite margin, and min_rival_margin withholds a pose whose
// rival fits the depth nearly as well.
TEST(PoseRefinementDepthIcp, APoseWithARivalThatFitsAsWellIsNotTrusted) {
  std::mt19937 rng(16);
  registration::ModelIndex index;
  ASSERT_TRUE(index.update(suite().model).isOk());
  const std::vector<Eigen::Isometry3d> symmetries =
      registration::motionsOf(registration::nearSymmetries(index));
  const Eigen::Isometry3d truth = drawTruth(rng, 6.0);
  // One start: no rival.
  auto alone = make(", symmetry_starts: false, min_rival_margin: 9");
  refine(*alone, truth, {truth}, 600);
  EXPECT_TRUE(std::isinf(*alone->out.rival_margin));
  // The truth and its three half turns: each converges where it started, the truth fits best.
  const std::vector<Eigen::Isometry3d> starts = pose_refinement::startsOf(truth, symmetries);
  auto lenient = make(", symmetry_starts: false, finalists: 4");
  const Errors e = refine(*lenient, truth, starts, 600);
  EXPECT_LT(e.angle_deg, 2.0);
  const double margin = *lenient->out.rival_margin;
  EXPECT_GT(margin, 0.0);
  EXPECT_LT(margin, 9.0);
  auto strict = make(fmt::format(", symmetry_starts: false, finalists: 4, min_rival_margin: {}",
                                 std::nextafter(margin, 10.0)));
  strict->in.detections.set(detectionsAt(starts));
  strict->in.depth.set(depthOf(truth, 600));
  strict->in.model.set(suite().model);
  ASSERT_TRUE(strict->process().isOk());
  EXPECT_FALSE(*strict->out.refined);
  EXPECT_TRUE(strict->out.pose.hasValue());  // the best guess, not trusted
  EXPECT_NEAR(*strict->out.rival_margin, margin, 1e-9);
}

// max_misfit: at the noise the depth has, a right pose's misfit is about 2 (each side's mean
// (r/sigma)^2 about 1); told a noise three times smaller than the depth's, the same pose's misfit
// is several times that, and the bound withholds it.
TEST(PoseRefinementDepthIcp, APoseThatLeavesTheDepthUnexplainedIsNotTrusted) {
  std::mt19937 rng(17);
  for (int draw = 0; draw < 3; ++draw) {
    const Eigen::Isometry3d truth = drawTruth(rng, 4.0 + 2.0 * draw);
    double misfit[2] = {0, 0};
    bool refined[2] = {false, false};
    for (int understated = 0; understated < 2; ++understated) {
      const double scale = understated ? 1.0 / 3.0 : 1.0;
      auto dfn = make(
          fmt::format(", symmetry_starts: false, min_fitness: 0, min_confirmed: 0, max_misfit: 3, "
                      "depth_noise_constant: {}, depth_noise_quadratic: {}",
                      kNoiseConstant * scale, kNoiseQuadratic * scale));
      dfn->in.detections.set(detectionsAt({truth}));
      dfn->in.depth.set(depthOf(truth, 700 + draw));
      dfn->in.model.set(suite().model);
      ASSERT_TRUE(dfn->process().isOk());
      misfit[understated] = *dfn->out.misfit;
      refined[understated] = *dfn->out.refined;
    }
    EXPECT_GT(misfit[0], 0.5) << "draw " << draw;
    EXPECT_LT(misfit[0], 3.0) << "draw " << draw;
    EXPECT_TRUE(refined[0]) << "draw " << draw;
    EXPECT_GT(misfit[1], 3.0) << "draw " << draw;
    EXPECT_FALSE(refined[1]) << "draw " << draw;
  }
}

// A ToF camera gives no depth where the return (reflectivity x cos / range^2) is below its
// threshold: beyond about 6 m the solar cells (reflectivity 0.12) and the adapter ring (0.1) of
// the procedural target vanish. Told the threshold and the model's reflectivity (its intensity),
// the refinement does not count their missing depth against the right pose.
TEST(PoseRefinementDepthIcp, ASurfaceTooDarkToReturnIsNoEvidenceAgainstThePose) {
  const Suite& s = suite();
  egse::TofSpec spec = s.spec;
  spec.min_amplitude = 0.002;  // the simulated ToF camera's
  egse::TofSensor sensor = egse::TofSensor::create(spec, "tof").value();
  std::vector<std::uint32_t> triangles;
  PointCloud model =
      sampleSurface(s.target.mesh, s.model.points.size(), 7, SampleNormals::kAuto, &triangles)
          .value();
  model.frame_id = "target";
  std::vector<float> reflectivity;
  for (std::uint32_t t : triangles)
    reflectivity.push_back(s.target.triangleMaterial(t).lidar_reflectivity);
  model.intensity = Buffer<float>::fromVector(std::move(reflectivity));
  std::mt19937 rng(17);
  double told_sum = 0, untold_sum = 0;
  const int draws = 4;
  for (int k = 0; k < draws; ++k) {
    const Eigen::Isometry3d truth = drawTruth(rng, 8.5);
    egse::Rng noise(700 + k);
    DepthMap depth = sensor.capture(*s.caster, s.target, truth, 0.0, noise).value();
    depth.image.frame_id = "camera";
    depth.image.stamp = 1000;
    double confirmed[2] = {0, 0}, misfit[2] = {0, 0};
    for (int told = 0; told < 2; ++told) {
      auto dfn = make(told ? ", symmetry_starts: false, min_amplitude: 0.002"
                           : ", symmetry_starts: false");
      dfn->in.detections.set(detectionsAt({truth}));
      dfn->in.depth.set(depth);
      dfn->in.model.set(model);
      ASSERT_TRUE(dfn->process().isOk());
      confirmed[told] = *dfn->out.confirmed;
      misfit[told] = *dfn->out.misfit;
    }
    // The right pose explains the depth better once the dark surfaces' missing depth is no
    // evidence (measured 1.2-4.7 against 4.1-7.2).
    EXPECT_LT(misfit[1], misfit[0] - 1.0) << "draw " << k;
    told_sum += confirmed[1];
    untold_sum += confirmed[0];
  }
  // Started at the truth, the shown points with a sure return mostly have their depth (0.77 on
  // average today: the outline's pixels and a few degrees of error at 8.5 m miss some); untold,
  // the dark surfaces count as missing (0.43 today).
  EXPECT_GT(told_sum / draws, 0.7);
  EXPECT_LT(untold_sum / draws, told_sum / draws - 0.2);
}

TEST(PoseRefinementDepthIcp, NoDetectionGivesNoPose) {
  std::mt19937 rng(14);
  auto dfn = make();
  dfn->in.detections.set(detectionsAt({}));
  dfn->in.depth.set(depthOf(drawTruth(rng, 8.0), 400));
  dfn->in.model.set(suite().model);
  ASSERT_TRUE(dfn->process().isOk());
  EXPECT_FALSE(*dfn->out.refined);
  EXPECT_EQ(*dfn->out.candidate, -1);
  EXPECT_FALSE(dfn->out.pose.hasValue());
  EXPECT_TRUE(std::isnan(*dfn->out.fitness));
  EXPECT_TRUE(dfn->out.candidates->detections.empty());
}

TEST(PoseRefinementDepthIcp, ADetectionWhereTheDepthShowsNoTargetIsNotRefined) {
  std::mt19937 rng(15);
  auto dfn = make();
  const Eigen::Isometry3d truth = drawTruth(rng, 8.0);
  Eigen::Isometry3d elsewhere = truth;
  elsewhere.translation() += Eigen::Vector3d(0, 0, 12.0);  // behind the target, nothing there
  dfn->in.detections.set(detectionsAt({elsewhere}));
  dfn->in.depth.set(depthOf(truth, 500));
  dfn->in.model.set(suite().model);
  ASSERT_TRUE(dfn->process().isOk());
  EXPECT_FALSE(*dfn->out.refined) << "fitness " << *dfn->out.fitness << ", confirmed "
                                  << *dfn->out.confirmed;
}

TEST(PoseRefinementDepthIcp, RejectsBadInput) {
  std::mt19937 rng(16);
  const Eigen::Isometry3d truth = drawTruth(rng, 8.0);
  const DepthMap depth = depthOf(truth, 600);
  auto ready = [&] {
    auto dfn = make();
    dfn->in.detections.set(detectionsAt({truth}));
    dfn->in.depth.set(depth);
    dfn->in.model.set(suite().model);
    return dfn;
  };
  {
    auto dfn = ready();
    DepthMap d = depth;
    d.image.camera.reset();
    dfn->in.depth.set(d);
    testing::expectRejected(*dfn, "input 'depth' has no camera model");
  }
  {
    auto dfn = ready();
    DepthMap d = depth;
    d.image.frame_id = "camera_right";
    dfn->in.depth.set(d);
    testing::expectRejected(*dfn, "in frame 'camera_right'");
  }
  {
    auto dfn = ready();
    DepthMap d = depth;
    d.image.camera->distortion_model = DistortionModel::kRadialTangential;
    d.image.camera->distortion = {0.1, 0, 0, 0, 0};
    dfn->in.depth.set(d);
    testing::expectRejected(*dfn, "lens distortion");
  }
  {
    auto dfn = ready();
    PointCloud bare = suite().model;
    bare.normals = {};
    dfn->in.model.set(bare);
    testing::expectRejected(*dfn, "input 'model'");
  }
  {
    auto dfn = ready();
    Detections d = detectionsAt({truth});
    d.detections[0].pose.translation.x() = std::nan("");
    dfn->in.detections.set(d);
    testing::expectRejected(*dfn, "input 'detections'");
  }
}

}  // namespace
}  // namespace cdff
