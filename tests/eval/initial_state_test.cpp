// The test bench's initial states (eval::perturbedInitialState) and the draw sets
// (eval::loadDrawSets, data/evaluation/draws.yaml): the initial error follows the distribution
// its covariance states, and draws are independent and reproducible.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "cdff/eval/draws.hpp"
#include "cdff/eval/initial_state.hpp"

namespace cdff::eval {
namespace {

#define EXPECT_OK(expr) EXPECT_TRUE((expr).isOk()) << (expr).toString()
#define ASSERT_OK(expr) ASSERT_TRUE((expr).isOk()) << (expr).toString()

constexpr double kDeg = M_PI / 180.0;

// The target 10 m ahead, still.
std::vector<Transform> truth() {
  std::vector<Transform> out;
  for (int k = 0; k <= 10; ++k) {
    Transform t = Transform::identity("servicer", "target", fromSeconds(k));
    t.translation = {1.0, -2.0, 9.7467943448};  // range 10.0 m
    t.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
    out.push_back(t);
  }
  return out;
}

struct Errors {
  std::vector<Eigen::Vector3d> position, attitude;
};

Errors draw(InitialErrorDistribution distribution, int n) {
  const std::vector<Transform> t = truth();
  Errors e;
  for (int seed = 1; seed <= n; ++seed) {
    InitialStatePerturbation p;
    p.position_fraction = 0.10;
    p.angle_rad = 10 * kDeg;
    p.distribution = distribution;
    p.seed = static_cast<std::uint64_t>(seed);
    Result<RigidBodyState> s = perturbedInitialState(t, fromSeconds(5), p);
    EXPECT_OK(s.status());
    if (!s) continue;
    e.position.push_back(s->pose.translation - t[5].translation);
    e.attitude.push_back(logSO3(s->pose.rotation * t[5].rotation.conjugate()));
    // The covariance is the Gaussian's: RMS size / sqrt(3) per axis, whatever was drawn.
    const double sigma_p = 0.10 * 10.0 / std::sqrt(3.0), sigma_r = 10 * kDeg / std::sqrt(3.0);
    EXPECT_NEAR(s->covariance(0, 0), sigma_p * sigma_p, 1e-9);
    EXPECT_NEAR(s->covariance(4, 4), sigma_r * sigma_r, 1e-12);
    EXPECT_NEAR(s->covariance(6, 6), 0.3 * 0.3, 1e-12);
    EXPECT_NEAR(s->covariance(11, 11), 0.1 * 0.1, 1e-12);
  }
  return e;
}

TEST(InitialState, GaussianErrorsHaveTheStatedRmsAndTails) {
  const int n = 4000;
  const Errors e = draw(InitialErrorDistribution::kGaussian, n);
  ASSERT_EQ(e.position.size(), static_cast<std::size_t>(n));
  // Per axis: zero mean and sigma = size / sqrt(3); with 4000 draws the sample sigma is within
  // about 2 % (1 standard error 1.1 %) and the mean within 0.05 sigma (3 standard errors).
  const double sigma_p = 1.0 / std::sqrt(3.0), sigma_r = 10 * kDeg / std::sqrt(3.0);
  Eigen::Vector3d mean_p = Eigen::Vector3d::Zero(), mean_r = Eigen::Vector3d::Zero();
  Eigen::Vector3d var_p = Eigen::Vector3d::Zero(), var_r = Eigen::Vector3d::Zero();
  std::size_t beyond_2_rms = 0;
  for (int i = 0; i < n; ++i) {
    mean_p += e.position[i] / n;
    mean_r += e.attitude[i] / n;
    var_p += e.position[i].cwiseAbs2() / n;
    var_r += e.attitude[i].cwiseAbs2() / n;
    beyond_2_rms += e.position[i].norm() > 2 * 1.0;
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(mean_p[a], 0, 0.05 * sigma_p);
    EXPECT_NEAR(mean_r[a], 0, 0.05 * sigma_r);
    EXPECT_NEAR(std::sqrt(var_p[a]), sigma_p, 0.03 * sigma_p);
    EXPECT_NEAR(std::sqrt(var_r[a]), sigma_r, 0.03 * sigma_r);
  }
  // Tails: |error| > 2 RMS is chi-square(3) > 12, probability 0.0074: about 30 of 4000.
  EXPECT_GE(beyond_2_rms, 12u);
  EXPECT_LE(beyond_2_rms, 55u);
}

TEST(InitialState, FixedSizeErrorsHaveExactlyTheStatedSize) {
  const Errors e = draw(InitialErrorDistribution::kFixedSize, 200);
  std::set<long> directions;
  for (std::size_t i = 0; i < e.position.size(); ++i) {
    EXPECT_NEAR(e.position[i].norm(), 1.0, 1e-9);
    EXPECT_NEAR(e.attitude[i].norm(), 10 * kDeg, 1e-9);
    directions.insert(std::lround(100 * e.position[i].x()));
  }
  EXPECT_GT(directions.size(), 50u);  // random directions
}

TEST(InitialState, TheSameSeedGivesTheSameStateAndBadInputIsAnError) {
  InitialStatePerturbation p;
  p.seed = 42;
  const Result<RigidBodyState> a = perturbedInitialState(truth(), fromSeconds(2), p);
  const Result<RigidBodyState> b = perturbedInitialState(truth(), fromSeconds(2), p);
  ASSERT_OK(a.status());
  ASSERT_OK(b.status());
  EXPECT_EQ(a->pose.translation, b->pose.translation);
  p.seed = 43;
  EXPECT_NE(perturbedInitialState(truth(), fromSeconds(2), p)->pose.translation,
            a->pose.translation);
  const Result<RigidBodyState> late = perturbedInitialState(truth(), fromSeconds(20), p);
  EXPECT_EQ(late.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(late.status().message().find("no ground truth at t = 20000000 us"), std::string::npos)
      << late.status().message();
  p.angle_rad = std::nan("");
  const Result<RigidBodyState> nan = perturbedInitialState(truth(), fromSeconds(2), p);
  EXPECT_EQ(nan.status().code(), StatusCode::kInvalidParameter);
  EXPECT_NE(nan.status().message().find("expected finite sizes >= 0"), std::string::npos)
      << nan.status().message();
}

// ---------------------------------------------------------------------------------------------
// Draw sets

const std::string kDrawFile = std::string(CDFF_SOURCE_DIR) + "/data/evaluation/draws.yaml";

TEST(DrawSets, TheRepositorySetsAreDisjointAndCiRunsEvaluationDraws) {
  Result<DrawSets> sets = loadDrawSets(kDrawFile);
  ASSERT_OK(sets.status());
  EXPECT_GE(sets->evaluation.count, 50u);
  EXPECT_GE(sets->ci, 1u);
  for (const Draw& d : sets->evaluationDraws()) {
    EXPECT_FALSE(sets->tuning.contains(d.number));
    EXPECT_FALSE(sets->tuning.contains(d.simulator_seed));
  }
  ASSERT_EQ(sets->ciDraws().size(), sets->ci);
  EXPECT_EQ(sets->ciDraws().front().number, sets->evaluation.first);
}

TEST(DrawSets, EachDrawHasItsOwnSimulatorSeedAndInitialErrorStream) {
  std::set<std::uint64_t> error_seeds;
  for (std::uint64_t n = 1; n <= 1000; ++n) {
    const Draw d = drawOf(n);
    EXPECT_EQ(d.simulator_seed, n);
    EXPECT_NE(d.initial_error_seed, n);
    error_seeds.insert(d.initial_error_seed);
  }
  EXPECT_EQ(error_seeds.size(), 1000u);
  EXPECT_EQ(drawOf(7).initial_error_seed, drawOf(7).initial_error_seed);
}

TEST(DrawSets, OverlappingSetsAndBadKeysAreErrorsThatSayWhere) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / "cdff_draws_overlap.yaml";
  {
    std::ofstream out(file);
    out << "tuning: {first: 1, count: 100}\nevaluation: {first: 50, count: 10}\nci: 2\n";
  }
  Result<DrawSets> overlap = loadDrawSets(file.string());
  EXPECT_EQ(overlap.status().code(), StatusCode::kInvalidParameter);
  EXPECT_NE(overlap.status().message().find(
                "cdff_draws_overlap.yaml:2:13: evaluation = {first: 50, count: 10}: [50, 60) "
                "overlaps them; expected draws disjoint from the tuning draws [1, 101)"),
            std::string::npos)
      << overlap.status().message();
  {
    std::ofstream out(file);
    out << "tuning: {first: 1, count: 100}\nevaluation: {first: 500, cont: 10}\nci: 2\n";
  }
  Result<DrawSets> typo = loadDrawSets(file.string());
  EXPECT_NE(typo.status().message().find("(did you mean 'count'?)"), std::string::npos)
      << typo.status().message();
  EXPECT_EQ(loadDrawSets("/nonexistent/draws.yaml").status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace cdff::eval
