// Cost of passing data between DFNs: a 2 MP image through 10 ports, shared (no copy) versus
// copied, and the core type conversions.
#include <benchmark/benchmark.h>

#include <cstring>

#include "FrameTransformation.gen.hpp"
#include "bench_support.hpp"
#include "cdff/dfn/port.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/types/opencv.hpp"
#include "cdff/types/pcl.hpp"

namespace {

constexpr int kHops = 10;

cdff::Image twoMegapixelImage() {
  // 1624 x 1234: the seed's Prosilica GC1600H, ~2.0 MP.
  return cdff::Image::fromBytes(std::vector<std::uint8_t>(1624 * 1234, 128), 1624, 1234,
                                cdff::PixelFormat::kGray8)
      .value();
}

// Typed hops: each DFN's output port hands its shared pointer to the next DFN's input port.
void BM_ImageThrough10TypedPorts(benchmark::State& state) {
  using namespace cdff::dfn;
  std::vector<std::unique_ptr<InputPort<cdff::Image>>> inputs;
  std::vector<std::unique_ptr<OutputPort<cdff::Image>>> outputs;
  for (int i = 0; i < kHops; ++i) {
    inputs.push_back(std::make_unique<InputPort<cdff::Image>>("in"));
    outputs.push_back(std::make_unique<OutputPort<cdff::Image>>("out"));
  }
  outputs[0]->set(twoMegapixelImage());
  for (auto _ : state) {
    for (int i = 0; i < kHops; ++i) {
      inputs[i]->set(outputs[i]->shared());
      if (i + 1 < kHops) outputs[i + 1]->set(inputs[i]->shared());
    }
    benchmark::DoNotOptimize(inputs.back()->get());
  }
  state.SetItemsProcessed(state.iterations() * kHops);  // items/s = hops per second
}
BENCHMARK(BM_ImageThrough10TypedPorts);

// Type-erased hops, as a DFPC graph connects ports it only knows at run time.
void BM_ImageThrough10TypeErasedPorts(benchmark::State& state) {
  using namespace cdff::dfn;
  std::vector<std::unique_ptr<InputPort<cdff::Image>>> inputs;
  std::vector<std::unique_ptr<OutputPort<cdff::Image>>> outputs;
  for (int i = 0; i < kHops; ++i) {
    inputs.push_back(std::make_unique<InputPort<cdff::Image>>("in"));
    outputs.push_back(std::make_unique<OutputPort<cdff::Image>>("out"));
  }
  outputs[0]->set(twoMegapixelImage());
  for (auto _ : state) {
    for (int i = 0; i < kHops; ++i) {
      InputPortBase& in = *inputs[i];
      const OutputPortBase& out = *outputs[i];
      benchmark::DoNotOptimize(in.setAny(out.anyValue()));
      if (i + 1 < kHops) outputs[i + 1]->set(inputs[i]->shared());
    }
    benchmark::DoNotOptimize(inputs.back()->get());
  }
  state.SetItemsProcessed(state.iterations() * kHops);
}
BENCHMARK(BM_ImageThrough10TypeErasedPorts);

// What a by-value design (the 2019 implementation) pays: one deep copy per hop.
void BM_ImageDeepCopiedThrough10Hops(benchmark::State& state) {
  std::vector<std::uint8_t> a(1624 * 1234, 128), b(a.size());
  for (auto _ : state) {
    for (int i = 0; i < kHops; ++i) {
      std::memcpy(b.data(), a.data(), a.size());
      std::swap(a, b);
    }
    benchmark::DoNotOptimize(a.data());
  }
}
BENCHMARK(BM_ImageDeepCopiedThrough10Hops)->Unit(benchmark::kMicrosecond);

void BM_ImageToCvMatView(benchmark::State& state) {
  const cdff::Image image = twoMegapixelImage();
  for (auto _ : state) benchmark::DoNotOptimize(cdff::toMat(image).data);
}
BENCHMARK(BM_ImageToCvMatView);

void BM_CvMatToImageView(benchmark::State& state) {
  cv::Mat mat(1234, 1624, CV_8UC1, cv::Scalar(1));
  for (auto _ : state) benchmark::DoNotOptimize(cdff::fromMat(mat).value().pixels.data());
}
BENCHMARK(BM_CvMatToImageView);

void BM_PointCloudFromPclView(benchmark::State& state) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->resize(30000);
  pcl::PointCloud<pcl::PointXYZ>::ConstPtr shared = cloud;
  for (auto _ : state) benchmark::DoNotOptimize(cdff::fromPcl(shared).points.data());
}
BENCHMARK(BM_PointCloudFromPclView);

void BM_PointCloudToPclCopy30k(benchmark::State& state) {
  std::vector<Eigen::Vector3f> xyz(30000, Eigen::Vector3f(1, 2, 3));
  const cdff::PointCloud cloud = cdff::PointCloud::fromXyz(xyz);
  for (auto _ : state) benchmark::DoNotOptimize(cdff::toPcl(cloud)->points.data());
}
BENCHMARK(BM_PointCloudToPclCopy30k)->Unit(benchmark::kMicrosecond);

// One DFN call from C++: a pose into FrameTransformation/Rigid, process(), the re-expressed pose
// out. bench/python_binding_bench.py runs the same call from Python and reports the difference
// (the binding's cost per call).
std::unique_ptr<cdff::dfn::FrameTransformation> frameTransformation() {
  auto node = cdff::dfn::Registry::instance()
                  .createAs<cdff::dfn::FrameTransformation>("FrameTransformation", "Rigid")
                  .value();
  cdff::Transform extrinsic = cdff::Transform::identity("servicer", "lidar");
  extrinsic.translation = Eigen::Vector3d(0.5, 0, 0);
  node->in.extrinsic.set(extrinsic);
  (void)node->configureDefaults();
  return node;
}

cdff::PoseWithCovariance lidarPose() {
  cdff::PoseWithCovariance pose;
  pose.pose = cdff::Transform::identity("lidar", "target", 1000);
  pose.pose.translation = Eigen::Vector3d(1, 2, 3);
  pose.covariance = cdff::Matrix6d::Identity() * 1e-4;
  return pose;
}

void BM_DfnCallFromCpp(benchmark::State& state) {
  auto node = frameTransformation();
  const cdff::PoseWithCovariance pose = lidarPose();
  for (auto _ : state) {
    node->in.pose.set(pose);  // a new value each call, as a caller's fresh measurement
    if (!node->process().isOk()) state.SkipWithError("process failed");
    benchmark::DoNotOptimize(node->out.pose.get());
  }
}
BENCHMARK(BM_DfnCallFromCpp);

void BM_DfnProcessOnlyFromCpp(benchmark::State& state) {
  auto node = frameTransformation();
  node->in.pose.set(lidarPose());
  for (auto _ : state)
    if (!node->process().isOk()) state.SkipWithError("process failed");
}
BENCHMARK(BM_DfnProcessOnlyFromCpp);

}  // namespace

CDFF_BENCHMARK_MAIN();
