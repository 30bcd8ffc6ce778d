// TemplateDetection/Linemod on views of the procedural target rendered with known poses.
//
// The detection tests train their templates once per test program on a coarse grid (30 degree
// view and in-plane steps, two ranges) so that training stays seconds; the test views are then
// drawn off that grid, so a correct detection is within the grid's reach of the truth: half a
// view step plus half an in-plane step (22.5 degrees, as the angles add at worst), and, once
// checked against the depth, within a few percent of the range. The tests of the template file
// and of bad input need only some trained views: they train a sparse grid (90 degrees, one range)
// in a fraction of that time.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <fmt/format.h>

#include "TemplateDetection.gen.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/types/opencv.hpp"
#include "linemod_training.hpp"
#include "support/dfn_testing.hpp"

namespace cdff {
namespace {

using dfn::TemplateDetection;
using namespace linemod_templates;

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kStep = 30 * kDeg;

/// The default stereo camera without its distortion (the detection matches rectified images).
CameraModel prosilica() {
  CameraModel m = egse::prosilicaGc1600h();
  m.distortion_model = DistortionModel::kNone;
  m.distortion.clear();
  return m;
}

double angleBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

const egse::TargetModel& targetModel() {
  static const egse::TargetModel model = egse::makeTargetSatellite().value();
  return model;
}

const TrainingOptions& defaultOptions() {
  static const TrainingOptions options = defaultTrainingOptions(targetModel(), prosilica());
  return options;
}

/// The template grid a test needs: the detection tests' (kDetection), or a sparse one for the
/// tests of the file and of bad input (kSparse).
enum class Grid { kDetection, kSparse };

struct Suite {
  TemplateSet set;
  std::filesystem::path dir, templates, model_file, other_model_file;
  double training_seconds = 0;
};

Suite train(Grid grid) {
  Suite out;
  TrainingOptions o = defaultOptions();
  o.view_step = o.in_plane_step = grid == Grid::kDetection ? kStep : 3 * kStep;
  o.ranges = grid == Grid::kDetection ? std::vector<double>{6.0, 7.5} : std::vector<double>{6.0};
  const auto t0 = std::chrono::steady_clock::now();
  out.set = trainTemplates(targetModel(), prosilica(), o).value();
  out.training_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.dir = std::filesystem::temp_directory_path() /
            fmt::format("cdff_template_detection_{}_{}", ::getpid(), static_cast<int>(grid));
  std::filesystem::create_directories(out.dir);
  out.templates = out.dir / "templates.yml.gz";
  EXPECT_TRUE(writeTemplateSet(out.set, out.templates).isOk());
  out.model_file = out.dir / "target.ply";
  EXPECT_TRUE(egse::writePly(targetModel(), out.model_file).isOk());
  out.other_model_file = out.dir / "hexagonal.ply";
  EXPECT_TRUE(egse::writePly(egse::makeHexagonalSatellite().value(), out.other_model_file).isOk());
  return out;
}

/// Trained once per test program and grid.
const Suite& suite(Grid grid = Grid::kDetection) {
  if (grid == Grid::kSparse) {
    static const Suite sparse = train(Grid::kSparse);
    return sparse;
  }
  static const Suite detection = train(Grid::kDetection);
  return detection;
}

/// A rendered test view as the DFN's inputs (matching resolution, its camera).
struct TestView {
  Image image;
  DepthMap depth;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
};

TestView renderView(const Eigen::Isometry3d& truth, const Eigen::Vector3d& sun) {
  ViewRenderer renderer =
      ViewRenderer::create(targetModel(), prosilica(), defaultOptions().pyramid_level,
                           egse::RendererBackend::kCpu, sun)
          .value();
  RenderedView view = renderer.render(truth).value();
  TestView t;
  t.truth = truth;
  t.image = fromMat(view.image.clone(), 1000, "camera_left_optical").value();
  t.image.camera = renderer.matchingCamera();
  cv::Mat metres;
  view.depth.convertTo(metres, CV_32F, 1e-3);
  metres.setTo(std::numeric_limits<float>::quiet_NaN(), view.depth == 0);
  t.depth.image = fromMat(metres, 1000, "camera_left_optical").value();
  t.depth.image.camera = renderer.matchingCamera();
  return t;
}

/// The truth pose: the model's bounding centre at `centre` (camera frame), rotated by q.
Eigen::Isometry3d poseAt(const Eigen::Quaterniond& q, const Eigen::Vector3d& centre) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = centre - pose.linear() * targetModel().boundingCentre();
  return pose;
}

std::unique_ptr<TemplateDetection> make(Grid grid, const std::string& extra = "") {
  return testing::makeDfn<TemplateDetection>(
      "TemplateDetection", "Linemod",
      fmt::format("{{template_file: '{}'{}}}", suite(grid).templates.string(), extra));
}

struct Errors {
  double angle = 1e9;  // deg
  double range = 1e9;  // fraction of the range
};

Errors errorsOf(const Detection& d, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d pose = d.pose.isometry();
  const Eigen::Vector3d centre = targetModel().boundingCentre();
  const Eigen::Vector3d c_true = truth * centre;
  return {angleBetween(pose.linear(), truth.linear()) / kDeg,
          ((pose * centre) - c_true).norm() / c_true.norm()};
}

const Eigen::Vector3d kFrontSun = TrainingOptions{}.sun_direction;
const Eigen::Vector3d kSideSun = Eigen::Vector3d(1.0, -0.2, -0.3).normalized();

TEST(TemplateDetectionLinemod, FindsATrainedViewAtItsPose) {
  const Suite& sparse = suite(Grid::kSparse);
  const TemplateView& t = sparse.set.templates[sparse.set.templates.size() / 3];
  const TestView view = renderView(t.camera_T_object, kFrontSun);
  auto dfn = make(Grid::kSparse);
  dfn->in.image.set(view.image);
  ASSERT_TRUE(dfn->process().isOk());
  ASSERT_TRUE(*dfn->out.detected);
  const Errors e = errorsOf(dfn->out.detections->detections.front(), view.truth);
  EXPECT_LT(e.angle, 1.0);
  EXPECT_LT(e.range, 0.01);
}

/// Views off the training grid (random attitude, range between and beyond the two trained
/// ranges, off-centre, lit from the side), with the depth: the target is found and placed.
/// Its attitude is not asserted: the procedural target is nearly symmetric under half turns
/// (a box bus between two wings), OpenCV's colour-gradient templates take their features on
/// the outline only, and the best match is most often the half-turned view (docs/detection.md).
TEST(TemplateDetectionLinemod, DetectsViewsOffTheGridWithDepth) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-1, 1);
  auto dfn = make(Grid::kDetection);
  const int n = 24;
  int correct = 0, placed = 0, detected = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
    const double depth = 6.0 + 1.5 * (0.5 + 0.5 * u(rng));
    const TestView view = renderView(
        poseAt(q, Eigen::Vector3d(0.1 * u(rng) * depth, 0.08 * u(rng) * depth, depth)), kSideSun);
    dfn->in.image.set(view.image);
    dfn->in.depth.set(view.depth);
    ASSERT_TRUE(dfn->process().isOk());
    if (!*dfn->out.detected) continue;
    ++detected;
    const Errors e = errorsOf(dfn->out.detections->detections.front(), view.truth);
    correct += e.angle < 22.5 && e.range < 0.1;
    placed += e.range < 0.1;
    fmt::print(
        "view {}: angle {:.1f} deg, centre {:.2f} % of the range, similarity {:.2f}, "
        "depth agreement {:.2f}\n",
        i, e.angle, 100 * e.range, dfn->out.detections->detections.front().similarity,
        dfn->out.detections->detections.front().depth_agreement);
  }
  fmt::print(
      "{} of {} detected, {} placed within 10 % of the range, {} also within the grid's "
      "angular reach (training {:.1f} s, {} templates)\n",
      detected, n, placed, correct, suite().training_seconds, suite().set.templates.size());
  // Today 14 of 24 are placed, 15 detected (a view lit from the side shows half its
  // outline); the bound guards that.
  EXPECT_GE(placed, n / 2);
}

/// The same kind of views as a ToF camera gives them: a depth and no image. Only the templates'
/// surface-normal part is matched; the target is found and placed at the measured depth.
TEST(TemplateDetectionLinemod, DetectsViewsFromTheirDepthAlone) {
  std::mt19937 rng(12);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-1, 1);
  auto dfn = make(Grid::kDetection);
  const int n = 24;
  int correct = 0, placed = 0, detected = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
    const double depth = 6.0 + 1.5 * (0.5 + 0.5 * u(rng));
    const TestView view = renderView(
        poseAt(q, Eigen::Vector3d(0.1 * u(rng) * depth, 0.08 * u(rng) * depth, depth)), kSideSun);
    dfn->in.depth.set(view.depth);
    ASSERT_TRUE(dfn->process().isOk()) << dfn->process().toString();
    if (!*dfn->out.detected) continue;
    ++detected;
    const Detection& best = dfn->out.detections->detections.front();
    EXPECT_EQ(best.pose.parent_frame, view.depth.image.frame_id);
    EXPECT_EQ(dfn->out.detections->stamp, view.depth.image.stamp);
    const Errors e = errorsOf(best, view.truth);
    correct += e.angle < 22.5 && e.range < 0.1;
    placed += e.range < 0.1;
  }
  fmt::print(
      "depth alone: {} of {} detected, {} placed within 10 % of the range, {} also within "
      "the grid's angular reach\n",
      detected, n, placed, correct);
  // Today all 24 are detected and 18 placed (the attitude, as with the image, is most often a
  // near-symmetric view); the bound guards that.
  EXPECT_GE(placed, 16);
}

TEST(TemplateDetectionLinemod, AnEmptySkyIsNotDetected) {
  auto dfn = make(Grid::kDetection);
  TestView view = renderView(poseAt(Eigen::Quaterniond::Identity(), {0, 0, 6}), kFrontSun);
  // Stars: isolated bright pixels on black, and no depth.
  cv::Mat sky = cv::Mat::zeros(view.image.height, view.image.width, CV_8UC1);
  std::mt19937 rng(3);
  for (int i = 0; i < 300; ++i)
    sky.at<std::uint8_t>(static_cast<int>(rng() % sky.rows), static_cast<int>(rng() % sky.cols)) =
        static_cast<std::uint8_t>(100 + rng() % 156);
  Image image = fromMat(sky, 1000, "camera_left_optical").value();
  image.camera = view.image.camera;
  dfn->in.image.set(image);
  ASSERT_TRUE(dfn->process().isOk());
  EXPECT_FALSE(*dfn->out.detected);
  EXPECT_TRUE(dfn->out.detections->detections.empty());
}

TEST(TemplateDetectionLinemod, TemplateFileRoundTrips) {
  const Suite& sparse = suite(Grid::kSparse);
  Result<TemplateSet> read = readTemplateSet(sparse.templates);
  ASSERT_TRUE(read) << read.status().toString();
  EXPECT_EQ(read->mesh_hash, sparse.set.mesh_hash);
  EXPECT_EQ(read->templates.size(), sparse.set.templates.size());
  EXPECT_EQ(read->detector->numTemplates(), sparse.set.detector->numTemplates());
  EXPECT_EQ(read->model_points.size(), sparse.set.model_points.size());
  const TemplateView& a = read->templates.back();
  const TemplateView& b = sparse.set.templates.back();
  EXPECT_LT((a.camera_T_object.matrix() - b.camera_T_object.matrix()).norm(), 1e-9);
  EXPECT_EQ(a.centre_offset, b.centre_offset);
  // The exported model has the same hash as the one trained on.
  EXPECT_EQ(meshHash(egse::loadModel(sparse.model_file).value().mesh), sparse.set.mesh_hash);
}

// ---- Bad input ---------------------------------------------------------------------------

Status configureWith(const std::string& yaml) {
  auto node = dfn::Registry::instance().createAs<TemplateDetection>("TemplateDetection", "Linemod");
  EXPECT_TRUE(node.isOk());
  return node.value()->configure(YAML::Load(yaml));
}

TEST(TemplateDetectionLinemodBadInput, MissingOrCorruptTemplateFile) {
  {
    auto dfn = testing::makeDfn<TemplateDetection>("TemplateDetection", "Linemod", "{}");
    dfn->in.image.set(
        renderView(poseAt(Eigen::Quaterniond::Identity(), {0, 0, 6}), kFrontSun).image);
    testing::expectRejected(*dfn, "'template_file' is empty", StatusCode::kInvalidParameter);
  }
  Status s = configureWith("{template_file: /nonexistent/templates.yml.gz}");
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("/nonexistent/templates.yml.gz"), std::string::npos) << s.message();
  // A truncated file.
  const std::filesystem::path cut = suite(Grid::kSparse).dir / "truncated.yml";
  {
    cv::FileStorage fs(cut.string(), cv::FileStorage::WRITE);
    fs << "format"
       << "cdff.linemod_templates"
       << "version" << 1;
  }
  s = configureWith(fmt::format("{{template_file: '{}'}}", cut.string()));
  EXPECT_EQ(s.code(), StatusCode::kCorruptData);
  EXPECT_NE(s.message().find("truncated.yml"), std::string::npos) << s.message();
  // Not a template file at all.
  const std::filesystem::path junk = suite(Grid::kSparse).dir / "junk.yml";
  std::ofstream(junk) << "this: [is, not\n";
  s = configureWith(fmt::format("{{template_file: '{}'}}", junk.string()));
  EXPECT_EQ(s.code(), StatusCode::kCorruptData);
  EXPECT_NE(s.message().find("junk.yml"), std::string::npos) << s.message();
}

TEST(TemplateDetectionLinemodBadInput, TemplatesOfAnotherMeshAreRefused) {
  const Suite& sparse = suite(Grid::kSparse);
  Status s =
      configureWith(fmt::format("{{template_file: '{}', model_file: '{}'}}",
                                sparse.templates.string(), sparse.other_model_file.string()));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("hash"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("hexagonal.ply"), std::string::npos) << s.message();
  s = configureWith(fmt::format("{{template_file: '{}', model_file: '{}'}}",
                                sparse.templates.string(), sparse.model_file.string()));
  EXPECT_TRUE(s.isOk()) << s.toString();
}

TEST(TemplateDetectionLinemodBadInput, ImagesOfAnotherCameraOrWithoutOneAreRefused) {
  auto dfn = make(Grid::kSparse);
  TestView view = renderView(poseAt(Eigen::Quaterniond::Identity(), {0, 0, 6}), kFrontSun);
  Image image = view.image;
  image.camera.reset();
  dfn->in.image.set(image);
  testing::expectRejected(*dfn, "input 'image' has no camera model");
  image = view.image;
  image.camera->fx *= 1.1;
  image.camera->fy *= 1.1;
  dfn->in.image.set(image);
  testing::expectRejected(*dfn, "were trained for");
  image = view.image;
  image.camera->distortion_model = DistortionModel::kRadialTangential;
  image.camera->distortion = {-0.1, 0.01, 0, 0, 0};
  dfn->in.image.set(image);
  testing::expectRejected(*dfn, "lens distortion");
  dfn->in.image.set(Image{});
  testing::expectRejected(*dfn, "input 'image'");
  // A depth map of another field of view.
  dfn->in.image.set(view.image);
  DepthMap depth = view.depth;
  depth.image.camera->fx *= 0.5;
  dfn->in.depth.set(depth);
  testing::expectRejected(*dfn, "does not cover the image's field of view");
}

TEST(TemplateDetectionLinemodBadInput, ADepthAloneMustBeInTheTemplatesCamera) {
  auto dfn = make(Grid::kSparse);
  testing::expectRejected(*dfn, "neither input 'image' nor input 'depth' has a value");
  TestView view = renderView(poseAt(Eigen::Quaterniond::Identity(), {0, 0, 6}), kFrontSun);
  DepthMap depth = view.depth;
  depth.image.camera.reset();
  dfn->in.depth.set(depth);
  testing::expectRejected(*dfn, "input 'depth' has no camera model");
  depth = view.depth;
  depth.image.camera->fx *= 1.1;
  depth.image.camera->fy *= 1.1;
  dfn->in.depth.set(depth);
  testing::expectRejected(*dfn, "input 'depth' has camera");
  dfn->in.depth.set(DepthMap{});
  testing::expectRejected(*dfn, "input 'depth'");
}

TEST(TemplateDetectionLinemodBadInput, DepthNormalsNeedADepth) {
  auto dfn = make(Grid::kSparse, ", depth_normals: true");
  TestView view = renderView(poseAt(Eigen::Quaterniond::Identity(), {0, 0, 6}), kFrontSun);
  dfn->in.image.set(view.image);
  testing::expectRejected(*dfn, "input 'depth' has no value");
}

}  // namespace
}  // namespace cdff
