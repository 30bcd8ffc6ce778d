// EstimationFilter (ExtendedKalman): the cost of one prediction and of one prediction +
// correction, i.e. what a DFPC pays per sensor frame for the 12-state SE(3) filter.
#include <benchmark/benchmark.h>

#include "EstimationFilter.gen.hpp"
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

}  // namespace

CDFF_BENCHMARK_MAIN();
