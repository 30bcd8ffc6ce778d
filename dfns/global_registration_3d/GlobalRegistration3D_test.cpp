// GlobalRegistration3D on simulated scans of the simulator's two procedural targets at random
// attitudes: a dense ToF-like scan must give a hypothesis near the truth among the first few, a
// sparse VLP-16 scan is reported, a scene without the target gets fewer votes, and bad inputs and
// parameters are reported. Both DFIs; their runtimes on a ~20k-point scene are printed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "GlobalRegistration3D.gen.hpp"
#include "cdff/egse/procedural.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"
#include "support/targets.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::unique_ptr<GlobalRegistration3D> make(const std::string& dfi, const std::string& yaml = "{}") {
  return testing::makeDfn<GlobalRegistration3D>("GlobalRegistration3D", dfi, yaml);
}

using Target = testing::ProceduralTarget;

/// The two targets, their models with the faces' normals (sampled once for all tests).
const std::vector<Target>& targets() {
  static const std::vector<Target> t = testing::proceduralTargets(SampleNormals::kFace);
  return t;
}

/// A ToF camera's dense points: 120 rows over +-15 deg, 0.1 deg columns, 5 mm range noise.
testing::ScanOptions denseScan() {
  testing::ScanOptions o;
  o.rings = 120;
  o.azimuth_step = 0.1 * kDeg;
  o.range_noise = 0.005;
  return o;
}

/// The criterion of a correct hypothesis: within 5 % of the range and 5 degrees.
bool correct(const Detection& d, const Eigen::Isometry3d& truth, double range) {
  const testing::PoseError e = testing::poseError(d.pose.isometry(), truth);
  return e.translation < 0.05 * range && e.rotation < 5.0 * kDeg;
}

/// The rank of the first correct hypothesis, -1 when none is.
int rankOfTruth(const Detections& hypotheses, const Eigen::Isometry3d& truth, double range) {
  for (std::size_t i = 0; i < hypotheses.detections.size(); ++i)
    if (correct(hypotheses.detections[i], truth, range)) return static_cast<int>(i);
  return -1;
}

/// The votes of a hypothesis, from its template_id "cluster <rank> (<votes> votes)".
double votesOf(const Detection& d) {
  const std::size_t open = d.template_id.find('(');
  return open == std::string::npos ? 0 : std::stod(d.template_id.substr(open + 1));
}

struct Rates {
  int draws = 0, first = 0, listed = 0;
};

/// Runs `dfi` on scans of both targets at ranges from `near` to `far`, attitudes from the seeds.
Rates measure(const std::string& dfi, const testing::ScanOptions& scan, double near, double far,
              int draws_per_target, std::uint32_t seed0) {
  Rates rates;
  for (const Target& target : targets()) {
    auto node = make(dfi);
    node->in.model.set(target.model);
    for (int k = 0; k < draws_per_target; ++k) {
      const std::uint32_t seed = seed0 + static_cast<std::uint32_t>(k);
      const double range = near + (far - near) * k / std::max(1, draws_per_target - 1);
      const Eigen::Isometry3d truth = testing::targetAhead(range, seed);
      node->in.scene.set(testing::simulateScan(target.mesh, truth, scan, 1000 + seed));
      const Status s = node->process();
      EXPECT_TRUE(s.isOk()) << s.toString();
      if (!s.isOk()) continue;
      const int rank = rankOfTruth(*node->out.hypotheses, truth, range);
      ++rates.draws;
      rates.first += rank == 0;
      rates.listed += rank >= 0;
      if (rank != 0) {
        std::printf("  %s %s range %.1f seed %u: rank %d of %zu, %d scene points\n", dfi.c_str(),
                    target.name.c_str(), range, seed, rank, node->out.hypotheses->detections.size(),
                    *node->out.scene_points);
      }
    }
  }
  std::printf("%s: first %d, listed %d of %d draws\n", dfi.c_str(), rates.first, rates.listed,
              rates.draws);
  return rates;
}

// Dense ToF-like scans of both targets at 3-8 m, 10 random attitudes each. Measured: a correct
// hypothesis (5 % of range, 5 deg, before any refinement) listed in 20 of 20 draws, first in 15;
// the first is otherwise usually a near-symmetric pose (the wings mirrored) that
// PoseHypothesisSelection tells apart. Asserted one draw below each.
TEST(GlobalRegistration3DPointPairVoting, DenseScansListTheTarget) {
  const Rates r = measure("PointPairVoting", denseScan(), 3.0, 8.0, 10, 1);
  EXPECT_EQ(r.draws, 20);
  EXPECT_GE(r.listed, 19);
  EXPECT_GE(r.first, 14);
}

// Sparse VLP-16 scans (16 rings, 2 deg apart: 17-35 cm between rings at 5-10 m) at 5-10 m.
// Measured: listed in 20 of 20 draws, first in 13 (a ring alone is a line: its points' normals
// come from grown neighbourhoods that reach the next ring, and fewer agree). Asserted one below.
TEST(GlobalRegistration3DPointPairVoting, SparseScansListTheTargetMostOfTheTime) {
  const Rates r = measure("PointPairVoting", {}, 5.0, 10.0, 10, 50);
  EXPECT_EQ(r.draws, 20);
  EXPECT_GE(r.listed, 19);
  EXPECT_GE(r.first, 12);
}

// OpenCV's detector runs on the same scenes without error, but its hypotheses are not correct
// (measured: a correct one listed in 0 of 20 dense draws, 0 of 20 sparse; translations often
// within 10 cm, rotations 90-180 deg off; see the report). Only what holds is asserted.
TEST(GlobalRegistration3DOpenCvPpf, DenseScansRunAndAreReported) {
  const Rates r = measure("OpenCvPpf", denseScan(), 3.0, 8.0, 10, 1);
  EXPECT_EQ(r.draws, 20);
}

/// The first hypothesis's votes on a scene, 0 when there is none.
double bestVotes(GlobalRegistration3D& node, const PointCloud& scene) {
  node.in.scene.set(scene);
  const Status s = node.process();
  EXPECT_TRUE(s.isOk()) << s.toString();
  if (!s.isOk() || node.out.hypotheses->detections.empty()) return 0;
  return votesOf(node.out.hypotheses->detections.front());
}

// A box of the bus's size (1.2 x 1.0 x 1.0 m) where the target would be: its faces match the
// bus's, but nothing else of the model, so its best cluster collects fewer votes than the
// target's own scan at the same place: measured 0.02 to 0.19 of them over 6 draws, asserted
// below 0.3.
TEST(GlobalRegistration3DPointPairVoting, ASceneWithoutTheTargetGetsFewerVotes) {
  const TriangleMesh box = testing::boxMesh(Eigen::Vector3d(0.6, 0.5, 0.5));
  for (const Target& target : targets()) {
    auto node = make("PointPairVoting");
    node->in.model.set(target.model);
    for (std::uint32_t seed = 1; seed <= 3; ++seed) {
      SCOPED_TRACE(target.name + " draw " + std::to_string(seed));
      const Eigen::Isometry3d truth = testing::targetAhead(5.0, seed);
      const double with_target =
          bestVotes(*node, testing::simulateScan(target.mesh, truth, denseScan(), 700 + seed));
      const double without =
          bestVotes(*node, testing::simulateScan(box, truth, denseScan(), 700 + seed));
      std::printf("%s draw %u: target %.0f votes, box %.0f votes\n", target.name.c_str(), seed,
                  with_target, without);
      EXPECT_LT(without, 0.3 * with_target);
    }
  }
}

// The budget is 0.2 s per scene of 20k points against a model of 5k on one core: the
// time per scene after the first call (which prepares the model) is printed for both DFIs and
// asserted within the budget for ours (measured 46 ms with every downsampled point a reference;
// model preparation 90 ms).
TEST(GlobalRegistration3D, TimingOnATwentyThousandPointScene) {
  const Target& target = targets().front();
  const Eigen::Isometry3d truth = testing::targetAhead(5.2, 5);
  const PointCloud scene = testing::simulateScan(target.mesh, truth, denseScan(), 1005);
  for (const std::string dfi : {"PointPairVoting", "OpenCvPpf"}) {
    auto node = make(dfi);
    node->in.model.set(target.model);
    node->in.scene.set(scene);
    auto seconds = [&] {
      const auto start = std::chrono::steady_clock::now();
      EXPECT_OK(node->process());
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    const double first = seconds();
    double per_scene = 0;
    constexpr int kRuns = 5;
    for (int i = 0; i < kRuns; ++i) per_scene += seconds() / kRuns;
    std::printf(
        "%s: %zu scene points (%d downsampled), model %zu points: first call %.1f ms, "
        "then %.1f ms per scene\n",
        dfi.c_str(), scene.size(), *node->out.scene_points, target.model.size(), 1e3 * first,
        1e3 * per_scene);
    if (dfi == "PointPairVoting") {
      EXPECT_LT(per_scene, 0.2);
    }
  }
}

// A scene whose points are further apart than the model's diameter forms no pair: no vote, no
// peak, no hypothesis, and no error.
TEST(GlobalRegistration3D, NoPeaksGiveNoHypotheses) {
  for (const std::string dfi : {"PointPairVoting", "OpenCvPpf"}) {
    SCOPED_TRACE(dfi);
    auto node = make(dfi);
    node->in.model.set(targets().front().model);
    std::vector<Eigen::Vector3f> far_apart;
    for (int i = 0; i < 5; ++i)
      far_apart.emplace_back(20.0f * static_cast<float>(i), static_cast<float>(i % 2),
                             static_cast<float>(i % 3));
    PointCloud scene = PointCloud::fromXyz(far_apart, "tof");
    scene.normals = Buffer<Point4f>::fromVector(std::vector<Point4f>(5, Point4f(-1, 0, 0)));
    node->in.scene.set(scene);
    ASSERT_OK(node->process());
    EXPECT_TRUE(node->out.hypotheses->detections.empty());
    EXPECT_EQ(*node->out.scene_points, 5);
  }
}

TEST(GlobalRegistration3D, BadInputsAndParametersAreReported) {
  const Target& target = targets().front();
  const PointCloud scan =
      testing::simulateScan(target.mesh, testing::targetAhead(5.0, 1), denseScan(), 1);
  for (const std::string dfi : {"PointPairVoting", "OpenCvPpf"}) {
    SCOPED_TRACE(dfi);
    auto node = make(dfi);
    node->in.model.set(target.model);
    node->in.scene.set(scan);

    node->in.scene.set(PointCloud{});
    testing::expectRejected(*node, "input 'scene' has no points");

    std::vector<Point4f> with_nan(scan.points.begin(), scan.points.end());
    with_nan[3].x = std::nanf("");
    PointCloud nan_scan = scan;
    nan_scan.points = Buffer<Point4f>::fromVector(std::move(with_nan));
    node->in.scene.set(nan_scan);
    testing::expectRejected(*node, "input 'scene' point 3");

    // Two points are too few, after downsampling, to fix a pose.
    node->in.scene.set(PointCloud::fromXyz({{5, 0, 0}, {5, 1, 0}}, "tof"));
    testing::expectRejected(*node, "after downsampling");
    node->in.scene.set(scan);

    node->in.model.set(PointCloud{});
    testing::expectRejected(*node, "input 'model' has no points");
    PointCloud bare = target.model;
    bare.normals = {};
    node->in.model.set(bare);
    testing::expectRejected(*node, "input 'model' (");
    testing::expectRejected(*node, "has no normals");
    node->in.model.set(target.model);

    for (const char* sampling : {"{sampling: 0}", "{sampling: 1}"}) {
      const Status s = node->configure(YAML::Load(sampling));
      EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << s.toString();
      EXPECT_NE(s.message().find("parameter 'sampling'"), std::string::npos) << s.message();
    }
    ASSERT_OK(node->configure(YAML::Load("{}")));
    // A model of 5 points: too few after downsampling to describe a shape.
    PointCloud tiny = target.model;
    tiny.points = Buffer<Point4f>::fromVector(
        std::vector<Point4f>(target.model.points.begin(), target.model.points.begin() + 5));
    tiny.normals = Buffer<Point4f>::fromVector(
        std::vector<Point4f>(target.model.normals.begin(), target.model.normals.begin() + 5));
    node->in.model.set(tiny);
    testing::expectRejected(*node, "points after downsampling");
    node->in.model.set(target.model);
    // The model in millimetres against the scene in metres: said, not searched.
    node->in.model.set(testing::inMillimetres(target.model));
    testing::expectRejected(*node, "times the scene; expected both in metres");
    node->in.model.set(target.model);

    // Still works afterwards.
    ASSERT_OK(node->process());
    EXPECT_FALSE(node->out.hypotheses->detections.empty());
  }
}

}  // namespace
}  // namespace cdff::dfn
