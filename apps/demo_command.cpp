// cdff demo: the foundation DFNs end to end (`make demo` runs the tracking chains instead,
// scripts/demo.sh).
//
// The demo runs every foundation DFN on synthetic data with known ground truth and reports how
// well each did and what it cost:
//  1. a camera chain: a textured scene seen by a distorted 1624x1234 camera (the seed's
//     Prosilica GC1600H with a 6 mm lens) from two viewpoints related by a known homography ->
//     ImageUndistortion -> EdgeDetection, FeaturesExtraction2D -> FeaturesMatching2D, checked
//     against the true homography;
//  2. a stereo pair of the same camera model -> StereoRectification, checked on row alignment;
//  3. the EstimationFilter on a constant-twist relative trajectory with noisy pose measurements,
//     checked against the true trajectory (RMSE against the measurement noise, NEES).
// It writes a JSON summary to OUT/summary.json.
#include <filesystem>
#include <fstream>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "EdgeDetection.gen.hpp"
#include "EstimationFilter.gen.hpp"
#include "FeaturesExtraction2D.gen.hpp"
#include "FeaturesMatching2D.gen.hpp"
#include "ImageUndistortion.gen.hpp"
#include "StereoRectification.gen.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/types/opencv.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

using nlohmann::json;

template <typename T>
std::unique_ptr<T> create(const std::string& dfn, const std::string& dfi) {
  auto node = dfn::Registry::instance().createAs<T>(dfn, dfi);
  return node ? std::move(node).value() : nullptr;
}

cv::Mat texturedScene(int width, int height, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, width - 1), y(0, height - 1), grey(10, 245);
  std::uniform_int_distribution<int> size(4, 40);
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(90));
  for (int i = 0; i < 2500; ++i) {
    const cv::Point c(x(rng), y(rng));
    if (i % 2)
      cv::circle(image, c, size(rng), cv::Scalar(grey(rng)), cv::FILLED);
    else
      cv::rectangle(image, cv::Rect(c, cv::Size(size(rng), size(rng))), cv::Scalar(grey(rng)),
                    cv::FILLED);
  }
  return image;
}

// Renders what a distorted camera sees of an ideal (pinhole) image: for every distorted pixel,
// look up the pinhole pixel it comes from.
cv::Mat distort(const cv::Mat& ideal, const CameraModel& camera) {
  std::vector<cv::Point2f> distorted;
  distorted.reserve(static_cast<std::size_t>(camera.width) * camera.height);
  for (int v = 0; v < camera.height; ++v)
    for (int u = 0; u < camera.width; ++u) distorted.emplace_back(u, v);
  std::vector<cv::Point2f> undistorted;
  const cv::Mat k = cameraMatrix(camera);
  cv::undistortPoints(distorted, undistorted, k, distortionCoefficients(camera), cv::noArray(), k);
  cv::Mat map(camera.height, camera.width, CV_32FC2, undistorted.data());
  cv::Mat out;
  cv::remap(ideal, out, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  return out;
}

json diagnosticsJson(const dfn::Node& node) {
  const auto& d = node.diagnostics();
  return {{"dfn", node.name()},
          {"calls", d.call_count},
          {"errors", d.error_count},
          {"mean_wall_ms", d.meanWallSeconds() * 1e3},
          {"mean_cpu_ms", d.meanCpuSeconds() * 1e3}};
}

struct Step {
  std::string what;
  Status status;
};

Status cameraChain(json& report, std::vector<const dfn::Node*>& nodes,
                   std::vector<std::unique_ptr<dfn::Node>>& keep) {
  const CameraModel camera = egse::prosilicaGc1600h();
  const cv::Mat scene = texturedScene(camera.width, camera.height, 2026);
  // Second viewpoint: a small rotation, zoom and shift of the (planar) scene.
  const cv::Mat h_true =
      (cv::Mat_<double>(3, 3) << 0.98, -0.08, 60, 0.08, 0.98, -25, 2e-6, -1e-6, 1);
  cv::Mat scene_b;
  cv::warpPerspective(scene, scene_b, h_true, scene.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      90);

  auto undistort = create<dfn::ImageUndistortion>("ImageUndistortion", "RemapCached");
  auto edges = create<dfn::EdgeDetection>("EdgeDetection", "Canny");
  auto extract_a = create<dfn::FeaturesExtraction2D>("FeaturesExtraction2D", "Orb");
  auto extract_b = create<dfn::FeaturesExtraction2D>("FeaturesExtraction2D", "Orb");
  auto match = create<dfn::FeaturesMatching2D>("FeaturesMatching2D", "BruteForceHamming");
  if (!undistort || !edges || !extract_a || !extract_b || !match)
    return notFound("a foundation DFN is not registered; run `cdff dfn list`");
  CDFF_RETURN_IF_ERROR(extract_a->configure(YAML::Load("max_features: 2000")));
  CDFF_RETURN_IF_ERROR(extract_b->configure(YAML::Load("max_features: 2000")));

  std::vector<std::shared_ptr<const Image>> undistorted;
  for (const cv::Mat* ideal : std::initializer_list<const cv::Mat*>{&scene, &scene_b}) {
    Result<Image> raw = fromMat(distort(*ideal, camera), 0, "camera_optical");
    if (!raw) return raw.status();
    raw->camera = camera;
    undistort->in.image.set(std::move(raw).value());
    CDFF_RETURN_IF_ERROR(undistort->process());
    undistorted.push_back(undistort->out.undistorted.shared());
  }
  edges->in.image.set(undistorted[0]);  // the same pixels, shared, not copied
  CDFF_RETURN_IF_ERROR(edges->process());
  extract_a->in.image.set(undistorted[0]);
  extract_b->in.image.set(undistorted[1]);
  CDFF_RETURN_IF_ERROR(extract_a->process());
  CDFF_RETURN_IF_ERROR(extract_b->process());
  match->in.query.set(extract_a->out.features.shared());
  match->in.train.set(extract_b->out.features.shared());
  CDFF_RETURN_IF_ERROR(match->process());

  // Ground truth: after undistortion both images are pinhole views related by h_true.
  const Correspondences2D& c = *match->out.correspondences;
  std::size_t inliers = 0;
  double sum_error = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    cv::Mat p = h_true * (cv::Mat_<double>(3, 1) << c.first[i].x(), c.first[i].y(), 1.0);
    const Eigen::Vector2d predicted(p.at<double>(0) / p.at<double>(2),
                                    p.at<double>(1) / p.at<double>(2));
    const double error = (predicted - c.second[i]).norm();
    if (error < 3.0) {
      ++inliers;
      sum_error += error;
    }
  }
  const double inlier_fraction = c.size() ? static_cast<double>(inliers) / c.size() : 0.0;
  report["camera_chain"] = {
      {"image", fmt::format("{}x{}", camera.width, camera.height)},
      {"edge_fraction", *edges->out.edge_fraction},
      {"features", {extract_a->out.features->size(), extract_b->out.features->size()}},
      {"matches", c.size()},
      {"inlier_fraction_3px", inlier_fraction},
      {"inlier_mean_error_px", inliers ? sum_error / inliers : 0.0}};
  fmt::print(
      "camera chain   {}x{}: {} / {} ORB features, {} matches, {:.1f} % within 3 px of the "
      "true homography (mean {:.2f} px)\n",
      camera.width, camera.height, extract_a->out.features->size(), extract_b->out.features->size(),
      c.size(), 100.0 * inlier_fraction, inliers ? sum_error / inliers : 0.0);
  for (dfn::Node* n : std::initializer_list<dfn::Node*>{undistort.get(), edges.get(),
                                                        extract_a.get(), match.get()})
    nodes.push_back(n);
  keep.push_back(std::move(undistort));
  keep.push_back(std::move(edges));
  keep.push_back(std::move(extract_a));
  keep.push_back(std::move(extract_b));
  keep.push_back(std::move(match));
  return Status::ok();
}

Status stereoChain(json& report, std::vector<const dfn::Node*>& nodes,
                   std::vector<std::unique_ptr<dfn::Node>>& keep) {
  // A 20 cm baseline rig whose right camera is also slightly rotated: rectification must
  // remove the rotation. Scene: random points 3 to 8 m away, drawn as small discs.
  const CameraModel camera = egse::prosilicaGc1600h();
  Transform right_T_left = Transform::identity("left_optical", "right_optical");
  right_T_left.rotation = expSO3(Eigen::Vector3d(0.01, -0.02, 0.005));
  right_T_left.translation = Eigen::Vector3d(-0.2, 0.002, 0.001);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> lateral(-2.0, 2.0), depth(3.0, 8.0);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < 200; ++i) points.emplace_back(lateral(rng), lateral(rng) * 0.75, depth(rng));
  const cv::Mat k = cameraMatrix(camera), d = distortionCoefficients(camera);
  std::vector<cv::Point2d> left_px, right_px;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, d, left_px);
  const Eigen::Vector3d rv = logSO3(right_T_left.rotation);
  cv::projectPoints(points, cv::Vec3d(rv.x(), rv.y(), rv.z()),
                    cv::Vec3d(right_T_left.translation.x(), right_T_left.translation.y(),
                              right_T_left.translation.z()),
                    k, d, right_px);
  auto draw = [&](const std::vector<cv::Point2d>& px) {
    cv::Mat image(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
    for (const auto& p : px) cv::circle(image, p, 6, cv::Scalar(255), cv::FILLED, cv::LINE_AA);
    return image;
  };
  StereoImagePair pair;
  Result<Image> left = fromMat(draw(left_px), 0, "left_optical");
  Result<Image> right = fromMat(draw(right_px), 0, "right_optical");
  if (!left || !right) return left ? right.status() : left.status();
  pair.left = std::move(left).value();
  pair.right = std::move(right).value();
  pair.left.camera = pair.right.camera = camera;
  pair.right_T_left = right_T_left;

  auto rectify = create<dfn::StereoRectification>("StereoRectification", "OpenCV");
  if (!rectify) return notFound("StereoRectification/OpenCV is not registered");
  rectify->in.stereo.set(pair);
  CDFF_RETURN_IF_ERROR(rectify->process());
  const StereoImagePair& rect = *rectify->out.rectified;

  // Row alignment: each disc's centroid must sit on the same row in both rectified images.
  auto centroids = [](const Image& image) {
    cv::Mat labels, stats, centres;
    cv::connectedComponentsWithStats(toMat(image) > 127, labels, stats, centres);
    std::vector<cv::Point2d> out;
    for (int i = 1; i < centres.rows; ++i)
      if (stats.at<int>(i, cv::CC_STAT_AREA) > 20)
        out.emplace_back(centres.at<double>(i, 0), centres.at<double>(i, 1));
    return out;
  };
  const auto cl = centroids(rect.left), cr = centroids(rect.right);
  std::vector<double> row_errors;
  for (const auto& p : cl) {
    double best = 1e9;
    for (const auto& q : cr)
      if (p.x - q.x > 0 && p.x - q.x < 400) best = std::min(best, std::abs(p.y - q.y));
    if (best < 10) row_errors.push_back(best);
  }
  std::sort(row_errors.begin(), row_errors.end());
  const double median = row_errors.empty() ? std::nan("") : row_errors[row_errors.size() / 2];
  report["stereo_chain"] = {{"baseline_m", *rectify->out.baseline},
                            {"matched_discs", row_errors.size()},
                            {"median_row_error_px", median}};
  fmt::print(
      "stereo chain   baseline {:.3f} m, {} discs matched, median row misalignment {:.2f} px\n",
      *rectify->out.baseline, row_errors.size(), median);
  nodes.push_back(rectify.get());
  keep.push_back(std::move(rectify));
  return Status::ok();
}

Status filterChain(json& report, std::vector<const dfn::Node*>& nodes,
                   std::vector<std::unique_ptr<dfn::Node>>& keep) {
  // Target tumbling at 2 deg/s and drifting at 5 cm/s in the servicer frame, observed at 10 Hz
  // with 5 cm / 1 deg pose noise for 60 s.
  auto ekf = create<dfn::EstimationFilter>("EstimationFilter", "ExtendedKalman");
  if (!ekf) return notFound("EstimationFilter/ExtendedKalman is not registered");
  const double sigma_p = 0.05, sigma_r = 1.0 * M_PI / 180.0;
  const Eigen::Vector3d v(0.05, -0.02, 0.01);
  const Eigen::Vector3d w = Eigen::Vector3d(1, 2, 0.5).normalized() * (2.0 * M_PI / 180.0);
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Vector3d p(1.0, -0.5, 10.0);
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  double sum_p2 = 0, sum_r2 = 0, sum_raw_p2 = 0;
  int counted = 0;
  for (int k = 0; k <= 600; ++k) {
    const double t = 0.1 * k;
    const Eigen::Vector3d p_true = p + v * t;
    const Eigen::Quaterniond q_true = expSO3(w * t) * q;
    PoseWithCovariance z;
    z.pose = Transform::identity("servicer", "target", fromSeconds(t));
    z.pose.translation = p_true + sigma_p * Eigen::Vector3d(n(rng), n(rng), n(rng));
    z.pose.rotation = expSO3(sigma_r * Eigen::Vector3d(n(rng), n(rng), n(rng))) * q_true;
    z.covariance.diagonal() << Eigen::Vector3d::Constant(sigma_p * sigma_p),
        Eigen::Vector3d::Constant(sigma_r * sigma_r);
    ekf->in.pose_measurement.set(z);
    CDFF_RETURN_IF_ERROR(ekf->process());
    if (t >= 10.0) {  // after the filter has settled
      const RigidBodyState& s = *ekf->out.state;
      sum_p2 += (s.pose.translation - p_true).squaredNorm();
      sum_r2 += std::pow(angularDistance(s.pose.rotation, q_true), 2);
      sum_raw_p2 += (z.pose.translation - p_true).squaredNorm();
      ++counted;
    }
  }
  const double rmse_p = std::sqrt(sum_p2 / counted), rmse_r = std::sqrt(sum_r2 / counted);
  const double raw_p = std::sqrt(sum_raw_p2 / counted);
  report["estimation_filter"] = {{"position_rmse_m", rmse_p},
                                 {"measurement_position_rmse_m", raw_p},
                                 {"attitude_rmse_deg", rmse_r * 180.0 / M_PI},
                                 {"measurement_attitude_sigma_deg", 1.0}};
  fmt::print(
      "pose filter    60 s at 10 Hz: position RMSE {:.1f} mm (measurements {:.1f} mm), "
      "attitude RMSE {:.2f} deg (measurements 1 deg per axis)\n",
      rmse_p * 1e3, raw_p * 1e3, rmse_r * 180.0 / M_PI);
  nodes.push_back(ekf.get());
  keep.push_back(std::move(ekf));
  return Status::ok();
}

int runDemo(const std::string& out_dir) {
  json report;
  std::vector<const dfn::Node*> nodes;
  std::vector<std::unique_ptr<dfn::Node>> keep;
  fmt::print("CDFF demo: foundation DFNs on synthetic data with ground truth\n\n");
  for (auto* chain : {&cameraChain, &stereoChain, &filterChain}) {
    Status s = chain(report, nodes, keep);
    if (!s) {
      fmt::print(stderr, "error: {}\n", s.toString());
      return 1;
    }
  }
  fmt::print("\n{:<40} {:>6} {:>12} {:>12}\n", "DFN instance", "calls", "wall ms/call",
             "cpu ms/call");
  for (const dfn::Node* n : nodes) {
    const auto& d = n->diagnostics();
    fmt::print("{:<40} {:>6} {:>12.3f} {:>12.3f}\n", n->name(), d.call_count,
               d.meanWallSeconds() * 1e3, d.meanCpuSeconds() * 1e3);
    report["timing"].push_back(diagnosticsJson(*n));
  }
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  const std::string path = out_dir + "/summary.json";
  std::ofstream file(path);
  if (ec || !(file << report.dump(2) << '\n')) {
    fmt::print(stderr, "error: cannot write {}; expected a writable directory\n", path);
    return 1;
  }
  fmt::print("\nsummary written to {}\n", path);
  return 0;
}

}  // namespace

void addDemoCommand(CLI::App& root, int& exit_code) {
  CLI::App* demo = root.add_subcommand(
      "demo",
      "Run the foundation DFNs end to end on simulated data (make demo runs the tracking chains)");
  auto out_dir = std::make_shared<std::string>("out/demo");
  demo->add_option("--out", *out_dir, "Directory for the summary (JSON)");
  demo->callback([out_dir, &exit_code] { exit_code = runDemo(*out_dir); });
}

}  // namespace cdff::app
