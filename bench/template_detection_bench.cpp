// TemplateDetection/Linemod: the time of one detection against the number of templates, with
// and without the depth check, and the raw cv::linemod::Detector::match on the same image (the
// peer: the DFN's own cost is the pyramid, the range selection, the poses and the depth check).
// Templates of the procedural target for the Prosilica camera at one range (8 m), view and
// in-plane steps of 30 and 20 degrees (about 600 and 1700 templates; matching time grows
// linearly with the count); the image is an untrained view at 8 m, side-lit, with its depth.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <unistd.h>

#include "TemplateDetection.gen.hpp"
#include "bench_support.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/types/opencv.hpp"
#include "linemod_training.hpp"

namespace cdff {
namespace {

using namespace linemod_templates;

constexpr double kDeg = 3.14159265358979323846 / 180;

/// The default stereo camera without its distortion (the detection matches rectified images).
CameraModel prosilica() {
  CameraModel m = egse::prosilicaGc1600h();
  m.distortion_model = DistortionModel::kNone;
  m.distortion.clear();
  return m;
}

struct Fixture {
  TemplateSet set;
  std::filesystem::path file;
  Image image;
  DepthMap depth;
};

const Fixture* fixture(int step_deg, benchmark::State& state) {
  static std::map<int, Fixture> cache;
  if (auto it = cache.find(step_deg); it != cache.end()) return &it->second;
  Result<egse::TargetModel> model = egse::makeTargetSatellite();
  if (!model) {
    state.SkipWithError(model.status().toString().c_str());
    return nullptr;
  }
  TrainingOptions o = defaultTrainingOptions(*model, prosilica());
  o.view_step = o.in_plane_step = step_deg * kDeg;
  o.ranges = {8.0};
  Result<TemplateSet> set = trainTemplates(*model, prosilica(), o);
  if (!set) {
    state.SkipWithError(set.status().toString().c_str());
    return nullptr;
  }
  Fixture f;
  f.file = std::filesystem::temp_directory_path() /
           fmt::format("cdff_template_bench_{}_{}.yml.gz", ::getpid(), step_deg);
  if (!writeTemplateSet(*set, f.file)) {
    state.SkipWithError("cannot write the templates");
    return nullptr;
  }
  // An untrained view: an attitude between the grid's, side-lit.
  Result<ViewRenderer> renderer =
      ViewRenderer::create(*model, prosilica(), o.pyramid_level, egse::RendererBackend::kCpu,
                           Eigen::Vector3d(1.0, -0.2, -0.3).normalized());
  if (!renderer) {
    state.SkipWithError(renderer.status().toString().c_str());
    return nullptr;
  }
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  truth.linear() = Eigen::Quaterniond(0.7, 0.3, -0.5, 0.4).normalized().toRotationMatrix();
  truth.translation() = Eigen::Vector3d(0.4, -0.2, 8.0) - truth.linear() * model->boundingCentre();
  Result<RenderedView> view = renderer->render(truth);
  if (!view) {
    state.SkipWithError(view.status().toString().c_str());
    return nullptr;
  }
  f.image = fromMat(view->image.clone(), 0, "camera").value();
  f.image.camera = renderer->matchingCamera();
  cv::Mat metres;
  view->depth.convertTo(metres, CV_32F, 1e-3);
  f.depth.image = fromMat(metres, 0, "camera").value();
  f.depth.image.camera = renderer->matchingCamera();
  f.set = std::move(set).value();
  return &cache.emplace(step_deg, std::move(f)).first->second;
}

void BM_TemplateDetection(benchmark::State& state, int step_deg, bool with_depth) {
  const Fixture* f = fixture(step_deg, state);
  if (!f) return;
  auto dfn = bench::createConfigured<dfn::TemplateDetection>(
      "TemplateDetection", "Linemod", fmt::format("{{template_file: '{}'}}", f->file.string()));
  if (!dfn) return state.SkipWithError("cannot create or configure the DFI");
  dfn->in.image.set(f->image);
  if (with_depth) dfn->in.depth.set(f->depth);
  for (auto _ : state) {
    const Status s = dfn->process();
    if (!s) return state.SkipWithError(s.toString().c_str());
    benchmark::DoNotOptimize(dfn->out.detections.get());
  }
  state.counters["templates"] = static_cast<double>(f->set.templates.size());
  state.counters["detections"] = static_cast<double>(dfn->out.detections->detections.size());
}

void BM_OpenCV_LinemodMatch(benchmark::State& state, int step_deg) {
  const Fixture* f = fixture(step_deg, state);
  if (!f) return;
  cv::Ptr<cv::linemod::Detector> detector = gradientOnlyDetector(f->set);
  const cv::Mat grey = toMat(f->image);
  const cv::Mat source =
      padTo(asColour(grey), matchableSize(grey.size(), f->set.settings.spreading));
  std::vector<cv::linemod::Match> matches;
  for (auto _ : state) {
    detector->match({source}, 75.0f, matches);
    benchmark::DoNotOptimize(matches.data());
  }
  state.counters["templates"] = static_cast<double>(f->set.templates.size());
}

BENCHMARK_CAPTURE(BM_TemplateDetection, Step30_Image, 30, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TemplateDetection, Step30_ImageAndDepth, 30, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_OpenCV_LinemodMatch, Step30, 30)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TemplateDetection, Step20_Image, 20, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TemplateDetection, Step20_ImageAndDepth, 20, true)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_OpenCV_LinemodMatch, Step20, 20)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace cdff

CDFF_BENCHMARK_MAIN();
