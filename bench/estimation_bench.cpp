// EstimationFilter (ExtendedKalman): the cost of one prediction and of one prediction +
// correction, i.e. what a DFPC pays per sensor frame for the 12-state SE(3) filter; and
// BearingToPosition (RangeAndDirection), a far-range bearing turned into the filter's position
// measurement; StateInversion (Rigid), the far-range state turned into the target state.
#include <benchmark/benchmark.h>

#include "BearingToPosition.gen.hpp"
#include "EstimationFilter.gen.hpp"
#include "StateInversion.gen.hpp"
#include "bench_support.hpp"

namespace {

std::unique_ptr<cdff::dfn::EstimationFilter> initialisedFilter() {
  auto ekf = cdff::bench::createConfigured<cdff::dfn::EstimationFilter>("EstimationFilter",
                                                                        "ExtendedKalman");
  cdff::RigidBodyState s;
  s.pose = cdff::Transform::identity("servicer", "target", 0);
  s.pose.translation = {0.5, -0.2, 10.0};
  s.twist.angular = {0.01, 0.02, 0.0};
  s.covariance = cdff::Matrix12d::Identity() * 1e-3;
  ekf->in.initial_state.set(s);
  (void)ekf->process();
  return ekf;
}

void BM_EstimationFilter_predict(benchmark::State& state) {
  auto ekf = initialisedFilter();
  cdff::Timestamp t = 0;
  for (auto _ : state) {
    ekf->in.time.set(t += 100'000);
    if (!ekf->process()) state.SkipWithError("predict failed");
  }
}
BENCHMARK(BM_EstimationFilter_predict);

void BM_EstimationFilter_predictAndCorrect(benchmark::State& state) {
  auto ekf = initialisedFilter();
  cdff::PoseWithCovariance z;
  z.pose = cdff::Transform::identity("servicer", "target", 0);
  z.pose.translation = {0.5, -0.2, 10.0};
  for (auto _ : state) {
    z.pose.stamp += 100'000;
    ekf->in.pose_measurement.set(z);
    if (!ekf->process()) state.SkipWithError("correct failed");
  }
}
BENCHMARK(BM_EstimationFilter_predictAndCorrect);

void BM_EstimationFilter_predictAndCorrectPosition(benchmark::State& state) {
  auto ekf = initialisedFilter();
  cdff::PoseWithCovariance z;
  z.pose = cdff::Transform::identity("servicer", "target", 0);
  z.pose.translation = {0.5, -0.2, 10.0};
  z.covariance.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * 0.25;
  for (auto _ : state) {
    z.pose.stamp += 100'000;
    ekf->in.position_measurement.set(z);
    if (!ekf->process()) state.SkipWithError("position correction failed");
  }
}
BENCHMARK(BM_EstimationFilter_predictAndCorrectPosition);

void BM_BearingToPosition(benchmark::State& state) {
  auto node = cdff::bench::createConfigured<cdff::dfn::BearingToPosition>("BearingToPosition",
                                                                          "RangeAndDirection");
  cdff::Bearing b;
  b.frame_id = "servicer";
  b.direction = Eigen::Vector3d(1.0, 0.02, -0.01).normalized();
  b.covariance = 4e-8 * (Eigen::Matrix3d::Identity() - b.direction * b.direction.transpose());
  b.range = 1500.0;
  b.range_variance = 1.0;
  for (auto _ : state) {
    b.stamp += 1'000'000;
    node->in.bearing.set(b);
    if (!node->process()) state.SkipWithError("BearingToPosition failed");
  }
}
BENCHMARK(BM_BearingToPosition);

void BM_StateInversion(benchmark::State& state) {
  auto node = cdff::bench::createConfigured<cdff::dfn::StateInversion>(
      "StateInversion", "Rigid", "{child_frame: target, unobserved_attitude_sigma: 180}");
  cdff::RigidBodyState s;
  s.pose = cdff::Transform::identity("lvlh", "servicer", 0);
  s.pose.translation = {0.5, -400.0, 2.0};
  s.twist.linear = {0.0, 1.5, 0.0};
  s.covariance = cdff::Matrix12d::Identity() * 1e-2;
  for (auto _ : state) {
    s.pose.stamp += 1'000'000;
    node->in.state.set(s);
    if (!node->process()) state.SkipWithError("StateInversion failed");
  }
}
BENCHMARK(BM_StateInversion);

}  // namespace

CDFF_BENCHMARK_MAIN();
