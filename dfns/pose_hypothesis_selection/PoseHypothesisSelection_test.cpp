// PoseHypothesisSelection/IcpMisfit on simulated VLP-16 scans (and a dense scan without a sensor
// description) of the simulator's two procedural targets: the hypothesis near the truth is
// chosen and refined among wrong ones, a scene without the target gives no pose, and bad inputs
// are reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "PoseHypothesisSelection.gen.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"
#include "support/targets.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::unique_ptr<PoseHypothesisSelection> make(const std::string& yaml = "{}") {
  return testing::makeDfn<PoseHypothesisSelection>("PoseHypothesisSelection", "IcpMisfit", yaml);
}

using Target = testing::ProceduralTarget;
using testing::modelOf;

/// The error of `pose` from the nearest of `truth` and its near-symmetric poses (the model's
/// near-symmetries, registration::nearSymmetries as the DFI finds them): what a scene that does
/// not tell a near-symmetric pair apart leaves.
testing::PoseError errorUpToSymmetry(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& truth,
                                     const PointCloud& model) {
  registration::ModelIndex index;
  EXPECT_TRUE(index.update(model).isOk());
  testing::PoseError best = testing::poseError(pose, truth);
  for (const Eigen::Isometry3d& s : registration::motionsOf(registration::nearSymmetries(index))) {
    const testing::PoseError e = testing::poseError(pose, truth * s);
    if (e.rotation < best.rotation) best = e;
  }
  return best;
}

std::vector<Target> targets() {
  return testing::proceduralTargets();
}

/// A dense scan as noisy as the simulated ToF camera at `range` (4 mm + 1.5 mm/m^2).
testing::ScanOptions tofLike(double range) {
  testing::ScanOptions tof;
  tof.rings = 120;
  tof.azimuth_step = 0.1 * kDeg;
  tof.range_noise = 0.004 + 0.0015 * range * range;
  return tof;
}

Detections hypothesesAt(const std::vector<Eigen::Isometry3d>& poses) {
  Detections d;
  d.stamp = 1'000'000;
  d.frame_id = "lidar";
  for (const Eigen::Isometry3d& p : poses) {
    Detection& detection = d.detections.emplace_back();
    detection.pose = Transform::fromIsometry(p, "lidar", "target", d.stamp);
    detection.similarity = 0.5;
  }
  return d;
}

void setInputs(PoseHypothesisSelection& node, const Target& target, const PointCloud& scene,
               const std::vector<Eigen::Isometry3d>& hypotheses, bool with_sensor = true) {
  node.in.model.set(target.model);
  node.in.scene.set(scene);
  node.in.hypotheses.set(hypothesesAt(hypotheses));
  if (with_sensor) node.in.sensor.set(testing::lidarInfo({}));
}

// The right hypothesis (the truth moved by what a Hough bin leaves: 5 cm, 3 deg) is chosen among
// one far off the target and one turned by 60 degrees, and refined to what one scan at 8 m
// supports: the tracker's figures at this range (0.5 deg, 2 cm at p95 over scans,
// docs/lidar-tracking.md) doubled for a single scan's registration. The turn by 60 degrees is a
// near-symmetry of the hexagonal target, and a half turn of the box target is verified as a
// rival: a scan that does not tell them apart may leave the pose ambiguous (not found), but the
// pose is the truth or its twin, and a pose found is the truth.
TEST(PoseHypothesisSelectionIcpMisfit, TheHypothesisNearTheTruthIsChosenAndRefined) {
  int found = 0;
  for (const Target& target : targets()) {
    for (std::uint32_t seed = 1; seed <= 4; ++seed) {
      SCOPED_TRACE(target.name + " draw " + std::to_string(seed));
      const Eigen::Isometry3d truth = testing::targetAhead(8.0, seed);
      const PointCloud scan = testing::simulateScan(target.mesh, truth, {}, 100 + seed);
      Eigen::Isometry3d far_off = truth;
      far_off.translation() += Eigen::Vector3d(0, 4.0, 0);
      const Eigen::Isometry3d turned =
          truth * Eigen::Isometry3d(Eigen::AngleAxisd(60 * kDeg, Eigen::Vector3d::UnitZ()));
      auto node = make();
      setInputs(*node, target, scan,
                {far_off, turned, testing::perturb(truth, 0.05, 3 * kDeg, seed)});
      ASSERT_OK(node->process());
      ASSERT_TRUE(node->out.pose.hasValue());
      EXPECT_NE(*node->out.chosen, 0);
      EXPECT_NE(*node->out.found, *node->out.ambiguous);
      const Eigen::Isometry3d pose = node->out.pose->pose.isometry();
      const testing::PoseError e = *node->out.found ? testing::poseError(pose, truth)
                                                    : errorUpToSymmetry(pose, truth, target.model);
      EXPECT_LT(e.rotation, 1.0 * kDeg);
      EXPECT_LT(e.translation, 0.04);
      EXPECT_GT(*node->out.fitness, 0.9);
      EXPECT_GT(*node->out.visibility, 0.8);
      EXPECT_GE(*node->out.margin, 0.0);
      found += *node->out.found;
    }
  }
  std::printf("found in %d of 8 draws\n", found);  // measured: 8
  EXPECT_GE(found, 7);
}

// A dense scan without the sensor's description (a ToF camera's or a reconstruction's points):
// no visibility term, the right pose (or, when the view shows nothing that breaks the box
// target's symmetry, its twin, ambiguous) refined closer (many more returns).
TEST(PoseHypothesisSelectionIcpMisfit, ADenseSceneWithoutASensorDescriptionWorksToo) {
  const Target target = targets().front();
  testing::ScanOptions dense;
  dense.rings = 120;
  dense.azimuth_step = 0.1 * kDeg;
  dense.range_noise = 0.005;
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(6.0, seed);
    const PointCloud scan = testing::simulateScan(target.mesh, truth, dense, 200 + seed);
    auto node = make();
    Eigen::Isometry3d far_off = truth;
    far_off.translation() += Eigen::Vector3d(0, -4.0, 0);
    setInputs(*node, target, scan, {far_off, testing::perturb(truth, 0.05, 3 * kDeg, seed)}, false);
    ASSERT_OK(node->process());
    ASSERT_TRUE(node->out.pose.hasValue());
    EXPECT_EQ(*node->out.chosen, 1);
    EXPECT_TRUE(std::isnan(*node->out.visibility));
    const Eigen::Isometry3d pose = node->out.pose->pose.isometry();
    const testing::PoseError e = *node->out.found ? testing::poseError(pose, truth)
                                                  : errorUpToSymmetry(pose, truth, target.model);
    EXPECT_LT(e.rotation, 0.5 * kDeg);
    EXPECT_LT(e.translation, 0.02);
  }
}

// A near-symmetric twin is verified even when no hypothesis proposes it: given only the box
// target's pose turned by one of its near-symmetries, the truth is found among the twins, and
// the two are compared (a finite margin). On a VLP-16 scan at 8 m the parts that break the
// symmetry decide; on a dense scan as noisy as a ToF camera at 7 m (7.7 cm) they drown in the
// noise, and the pose is withheld (ambiguous) rather than a coin toss. With min_margin 0 the
// better one is taken whatever its edge.
TEST(PoseHypothesisSelectionIcpMisfit, NearSymmetricTwinsAreComparedAndAmbiguityIsReported) {
  const Target target = targets().front();
  registration::ModelIndex index;
  ASSERT_OK(index.update(target.model));
  const std::vector<Eigen::Isometry3d> symmetries =
      registration::motionsOf(registration::nearSymmetries(index));
  ASSERT_FALSE(symmetries.empty());
  const testing::ScanOptions tof = tofLike(7.0);
  for (const bool dense : {false, true}) {
    int found = 0, ambiguous = 0;
    for (std::uint32_t seed = 1; seed <= 4; ++seed) {
      SCOPED_TRACE(std::string(dense ? "dense" : "sparse") + " draw " + std::to_string(seed));
      const Eigen::Isometry3d truth = testing::targetAhead(dense ? 7.0 : 8.0, seed);
      const PointCloud scan = testing::simulateScan(
          target.mesh, truth, dense ? tof : testing::ScanOptions{}, 500 + seed);
      const std::vector<Eigen::Isometry3d> twin{truth * symmetries.front()};
      const std::string noise = dense ? "noise_constant: 0.004, noise_quadratic: 0.0015" : "";
      auto strict = make("{" + noise + "}");
      setInputs(*strict, target, scan, twin, !dense);
      ASSERT_OK(strict->process());
      ASSERT_TRUE(strict->out.pose.hasValue());
      EXPECT_TRUE(std::isfinite(*strict->out.margin));
      EXPECT_EQ(*strict->out.ambiguous,
                *strict->out.margin < 2.0 || *strict->out.relative_margin < 0.25);
      ambiguous += *strict->out.ambiguous;
      found += *strict->out.found;
      if (*strict->out.found) {
        EXPECT_LT(testing::poseError(strict->out.pose->pose.isometry(), truth).rotation,
                  2.5 * kDeg);
      }
      auto lenient = make("{min_margin: 0, min_relative_margin: 0" +
                          (dense ? ", " + noise : std::string()) + "}");
      setInputs(*lenient, target, scan, twin, !dense);
      ASSERT_OK(lenient->process());
      EXPECT_TRUE(*lenient->out.found);
      EXPECT_FALSE(*lenient->out.ambiguous);
    }
    std::printf("%s: found %d, ambiguous %d of 4 draws\n", dense ? "dense" : "sparse", found,
                ambiguous);
    // Measured: sparse found in 4 of 4; dense found in 3, ambiguous in 1.
    if (!dense) {
      EXPECT_GE(found, 3);
    }
  }
}

// confirmations: a pose is found once it has been the candidate on that many consecutive calls
// (scans of the target at the same place, each its own noise); a call where nothing passes (the
// only hypothesis 10 m off the target, no return there) starts the count anew.
TEST(PoseHypothesisSelectionIcpMisfit, ConfirmationsNeedConsecutiveCallsAtTheSamePose) {
  const Target target = targets()[1];  // hexagonal: decided on single VLP-16 scans at 8 m
  const Eigen::Isometry3d truth = testing::targetAhead(8.0, 2);
  auto node = make("{confirmations: 3}");
  auto call = [&](std::uint32_t noise_seed, double offset) {
    const PointCloud scan = testing::simulateScan(target.mesh, truth, {}, noise_seed);
    Eigen::Isometry3d hypothesis = testing::perturb(truth, 0.05, 3 * kDeg, noise_seed);
    hypothesis.translation().y() += offset;
    setInputs(*node, target, scan, {hypothesis});
    EXPECT_OK(node->process());
  };
  for (std::uint32_t k = 1; k <= 3; ++k) {
    SCOPED_TRACE("call " + std::to_string(k));
    call(600 + k, 0);
    ASSERT_TRUE(node->out.pose.hasValue());
    EXPECT_FALSE(*node->out.ambiguous);
    EXPECT_EQ(*node->out.found, k == 3);
    EXPECT_LT(testing::poseError(node->out.pose->pose.isometry(), truth).rotation, 1 * kDeg);
  }
  call(700, 10.0);
  EXPECT_FALSE(node->out.pose.hasValue());
  EXPECT_FALSE(*node->out.found);
  call(701, 0);
  EXPECT_TRUE(node->out.pose.hasValue());
  EXPECT_FALSE(*node->out.found);  // the count starts anew
}

// A dense scene as noisy as a ToF camera at 7 m (4 mm + 1.5 mm/m^2: 7.7 cm): described by the
// noise parameters, the right pose explains nearly every return; told nothing (three model
// spacings, 6 cm), too many fall outside and the pose is withheld.
TEST(PoseHypothesisSelectionIcpMisfit, TheStatedRangeNoiseSetsTheInlierDistance) {
  const Target target = targets().front();
  const double range = 7.0;
  const testing::ScanOptions tof = tofLike(range);
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(range, seed);
    const PointCloud scan = testing::simulateScan(target.mesh, truth, tof, 400 + seed);
    const std::vector<Eigen::Isometry3d> hypotheses{testing::perturb(truth, 0.05, 3 * kDeg, seed)};
    auto described = make("{noise_constant: 0.004, noise_quadratic: 0.0015}");
    setInputs(*described, target, scan, hypotheses, false);
    ASSERT_OK(described->process());
    ASSERT_TRUE(described->out.pose.hasValue());  // passes (found, or ambiguous with a twin)
    EXPECT_GT(*described->out.fitness, 0.95);
    const Eigen::Isometry3d pose = described->out.pose->pose.isometry();
    const testing::PoseError e = *described->out.found
                                     ? testing::poseError(pose, truth)
                                     : errorUpToSymmetry(pose, truth, target.model);
    // One such scan turns the pose by up to 1.9 degrees about its least constrained axis (0.2
    // to 1.9 over the draws): within half the 5 degrees of a correct detection.
    EXPECT_LT(e.rotation, 2.5 * kDeg);
    EXPECT_LT(e.translation, 0.04);
    auto untold = make();
    setInputs(*untold, target, scan, hypotheses, false);
    ASSERT_OK(untold->process());
    EXPECT_FALSE(*untold->out.found);
    EXPECT_FALSE(untold->out.pose.hasValue());
    EXPECT_LT(*untold->out.fitness, 0.85);
  }
}

/// `scan` with the returns left of the line of sight to the target (y above their median, in
/// the LIDAR's frame) moved along their rays to half their range: a plate in front of the
/// target that hides half of it and returns as the target does.
PointCloud occludedHalf(const PointCloud& scan) {
  std::vector<float> ys;
  for (const Point4f& p : scan.points) ys.push_back(p.y);
  std::nth_element(ys.begin(), ys.begin() + static_cast<std::ptrdiff_t>(ys.size() / 2), ys.end());
  const float median = ys[ys.size() / 2];
  std::vector<Point4f> points(scan.points.begin(), scan.points.end());
  for (Point4f& p : points)
    if (p.y > median) p = Point4f(0.5f * p.x, 0.5f * p.y, 0.5f * p.z);
  PointCloud occluded = scan;
  occluded.points = Buffer<Point4f>::fromVector(std::move(points));
  return occluded;
}

// An occluder in front of the target hides half of it: the model surface behind it has no
// return there, but a return in front on the same laser, which says the surface is hidden
// rather than absent. The right pose keeps its visibility (measured 0.98-1.00 over the draws;
// counted against the crop's returns alone, 0.47-0.61, about the min_visibility bound).
TEST(PoseHypothesisSelectionIcpMisfit, AnOccluderInFrontHidesTheSurfaceRatherThanDenyingIt) {
  const Target target = targets().front();
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(8.0, seed);
    const PointCloud scan = occludedHalf(testing::simulateScan(target.mesh, truth, {}, 300 + seed));
    auto node = make();
    setInputs(*node, target, scan, {testing::perturb(truth, 0.05, 3 * kDeg, seed)});
    ASSERT_OK(node->process());
    std::printf("draw %u: visibility %.2f fitness %.2f\n", seed, *node->out.visibility,
                *node->out.fitness);
    EXPECT_GT(*node->out.visibility, 0.85);
    ASSERT_TRUE(node->out.pose.hasValue());
    const Eigen::Isometry3d pose = node->out.pose->pose.isometry();
    const testing::PoseError e = *node->out.found ? testing::poseError(pose, truth)
                                                  : errorUpToSymmetry(pose, truth, target.model);
    EXPECT_LT(e.rotation, 2.5 * kDeg);
  }
}

/// The hexagonal target's mesh without its solar wing: what a ToF camera returns of it where the
/// dark cells are below its amplitude threshold.
TriangleMesh withoutWing() {
  const egse::TargetModel model = egse::makeHexagonalSatellite().value();
  std::vector<std::array<std::uint32_t, 3>> kept;
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t)
    if (model.parts[model.triangle_part[t]] != "solar_wing")
      kept.push_back(model.mesh.triangles[t]);
  TriangleMesh mesh = model.mesh;
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(kept));
  return mesh;
}

// A lopsided model (the hexagonal target: one solar wing moves its bounding box's centre by
// metres along +y) on a scene that shows only its bus (a ToF camera's view where the dark cells
// return nothing), under a range-dependent noise: each of the truth's near-symmetric twins (turns
// about the hexagon's axis) puts the box's centre elsewhere, nearer or farther, but both are
// scored at the noise of the returns they explain, so no twin wins by a farther centre's larger
// noise, and a pose found is the truth. At 8 m (0.1 m of noise) the bus's small parts do not
// tell the twins apart: measured, all 6 draws ambiguous; scored at the noise of the box's
// centre, draws 2 and 3 were found 120 degrees off.
TEST(PoseHypothesisSelectionIcpMisfit, ALopsidedModelsTwinsAreScoredAtTheNoiseOfTheSameReturns) {
  const Target target = targets().back();
  ASSERT_EQ(target.name, "hexagonal");
  const TriangleMesh bus = withoutWing();
  registration::ModelIndex index;
  ASSERT_OK(index.update(target.model));
  const std::vector<Eigen::Isometry3d> symmetries =
      registration::motionsOf(registration::nearSymmetries(index));
  ASSERT_FALSE(symmetries.empty());
  const double range = 8.0;
  const testing::ScanOptions tof = tofLike(range);
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(range, seed);
    const PointCloud scan = testing::simulateScan(bus, truth, tof, 700 + seed);
    std::vector<Eigen::Isometry3d> hypotheses{truth};
    for (const Eigen::Isometry3d& s : symmetries) hypotheses.push_back(truth * s);
    auto node = make("{noise_constant: 0.004, noise_quadratic: 0.0015}");
    setInputs(*node, target, scan, hypotheses, false);
    ASSERT_OK(node->process());
    ASSERT_TRUE(node->out.pose.hasValue());
    if (*node->out.found) {
      EXPECT_LT(testing::poseError(node->out.pose->pose.isometry(), truth).rotation, 2.5 * kDeg);
    }
    // The candidates: the truth and its twins, distinct, the pose output among them.
    const Detections& candidates = *node->out.candidates;
    ASSERT_GE(candidates.detections.size(), 2u);
    EXPECT_EQ(candidates.frame_id, "lidar");
    for (std::size_t i = 0; i < candidates.detections.size(); ++i)
      for (std::size_t j = i + 1; j < candidates.detections.size(); ++j)
        EXPECT_GT(testing::poseError(candidates.detections[i].pose.isometry(),
                                     candidates.detections[j].pose.isometry())
                      .rotation,
                  10 * kDeg);
  }
}

/// The hexagonal target's solar wing alone, moved by `motion` in the target's frame.
TriangleMesh wingMovedBy(const Eigen::Isometry3d& motion) {
  const egse::TargetModel model = egse::makeHexagonalSatellite().value();
  std::vector<std::array<std::uint32_t, 3>> kept;
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t)
    if (model.parts[model.triangle_part[t]] == "solar_wing")
      kept.push_back(model.mesh.triangles[t]);
  TriangleMesh mesh = model.mesh;
  mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(kept));
  std::vector<Eigen::Vector3f> moved;
  for (const Eigen::Vector3f& v : model.mesh.vertices)
    moved.push_back((motion * v.cast<double>()).cast<float>());
  mesh.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(moved));
  mesh.vertex_normals = {};
  return mesh;
}

// A dense scan of the hexagonal target beside a panel like its wing (a second object: debris,
// the servicer's own structure), far enough that neither's crop reaches the other, the crops
// thinned hard (max_points 300). The model at the panel explains the panel's returns as well as
// the truth explains the target's, but the target returns several times as many (bus and wing).
// Every pose is scored on the same subsample of the scene, so the truth's evidence counts them
// all and it is found; thinning each crop to 300 on its own would weigh each of the panel's
// fewer returns more and make the two a coin toss (measured: the panel's pose found in draw 2).
// The relative margin compares the two misfits over the returns of both crops.
TEST(PoseHypothesisSelectionIcpMisfit, PosesWhoseCropsHoldFewerReturnsAreScoredOnTheSameSubsample) {
  const Target target = targets().back();
  ASSERT_EQ(target.name, "hexagonal");
  registration::ModelIndex index;
  ASSERT_OK(index.update(target.model));
  const double radius = registration::modelBounds(index).radius();
  const double range = 6.0;
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(range, seed);
    // Beside the target at the same range (the same noise), the crops apart: 3 radii between
    // the two.
    const double apart = 2.0 * std::asin(std::min(1.0, 1.5 * radius / range));
    const Eigen::Isometry3d decoy = Eigen::AngleAxisd(apart, Eigen::Vector3d::UnitZ()) * truth;
    const TriangleMesh scene_mesh =
        testing::mergeMeshes({target.mesh, wingMovedBy(truth.inverse() * decoy)});
    const PointCloud scan = testing::simulateScan(scene_mesh, truth, tofLike(range), 800 + seed);
    auto node = make(
        "{noise_constant: 0.004, noise_quadratic: 0.0015, max_points: 300, symmetry_rivals: "
        "false}");
    setInputs(*node, target, scan, {decoy, truth}, false);
    ASSERT_OK(node->process());
    ASSERT_TRUE(*node->out.found);
    EXPECT_LT(testing::poseError(node->out.pose->pose.isometry(), truth).rotation, 2.5 * kDeg);
    // Measured 49-120 over the 4 draws (3.5 and a wrong pose with per-crop thinning).
    EXPECT_GT(*node->out.margin, 20.0);
  }
}

// The box target's model against a scan of the hexagonal target at the same place (both about
// the same size, a bus and wings): whatever the hypothesis, a quarter of the returns or more stay
// unexplained, so nothing is found (no pose rather than a wrong one).
TEST(PoseHypothesisSelectionIcpMisfit, ASceneWithoutTheTargetGivesNoPose) {
  const std::vector<Target> t = targets();
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE("draw " + std::to_string(seed));
    const Eigen::Isometry3d truth = testing::targetAhead(8.0, seed);
    const PointCloud scan = testing::simulateScan(t[1].mesh, truth, {}, 300 + seed);
    std::vector<Eigen::Isometry3d> hypotheses{truth};
    for (std::uint32_t k = 0; k < 5; ++k)
      hypotheses.push_back(testing::perturb(truth, 0.1, M_PI, 10 * seed + k));
    auto node = make();
    setInputs(*node, t[0], scan, hypotheses);
    ASSERT_OK(node->process());
    EXPECT_LT(*node->out.fitness, 0.8);  // the hexagonal bus and wing where the box's are not
    EXPECT_FALSE(*node->out.found);
    EXPECT_FALSE(node->out.pose.hasValue());
    EXPECT_EQ(*node->out.chosen, -1);
    EXPECT_TRUE(node->out.candidates->detections.empty());
  }
}

TEST(PoseHypothesisSelectionIcpMisfit, NoHypothesesFindNothing) {
  const Target target = targets().front();
  const PointCloud scan = testing::simulateScan(target.mesh, testing::targetAhead(8.0, 1), {}, 1);
  auto node = make();
  setInputs(*node, target, scan, {});
  ASSERT_OK(node->process());
  EXPECT_FALSE(*node->out.found);
  EXPECT_TRUE(std::isnan(*node->out.fitness));
}

TEST(PoseHypothesisSelectionIcpMisfit, BadInputsAreReported) {
  const Target target = targets().front();
  const Eigen::Isometry3d truth = testing::targetAhead(8.0, 1);
  const PointCloud scan = testing::simulateScan(target.mesh, truth, {}, 1);
  auto node = make();
  setInputs(*node, target, scan, {truth});

  std::vector<Point4f> with_nan(scan.points.begin(), scan.points.end());
  with_nan[3].x = std::nanf("");
  PointCloud nan_scan = scan;
  nan_scan.points = Buffer<Point4f>::fromVector(std::move(with_nan));
  node->in.scene.set(nan_scan);
  testing::expectRejected(*node, "input 'scene' point 3");
  node->in.scene.set(scan);

  Detections elsewhere = hypothesesAt({truth});
  elsewhere.frame_id = "camera";
  node->in.hypotheses.set(elsewhere);
  testing::expectRejected(*node, "input 'hypotheses' are in frame 'camera'");
  node->in.hypotheses.set(hypothesesAt({truth}));

  node->in.sensor.set(testing::lidarInfo({}, "velodyne"));
  testing::expectRejected(*node, "but input 'scene' is in frame 'lidar'");
  node->in.sensor.set(testing::lidarInfo({}));

  PointCloud bare = target.model;
  bare.normals = {};
  node->in.model.set(bare);
  testing::expectRejected(*node, "has no normals");
  // The model in millimetres against the scene in metres: said, rather than no pose found.
  node->in.model.set(testing::inMillimetres(target.model));
  testing::expectRejected(*node, "times the scene; expected both in metres");
  node->in.model.set(target.model);

  // Still works afterwards.
  ASSERT_OK(node->process());
  EXPECT_TRUE(node->out.pose.hasValue());
}

}  // namespace
}  // namespace cdff::dfn
