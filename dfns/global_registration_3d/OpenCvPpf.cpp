// GlobalRegistration3D/OpenCvPpf: the same point pair feature voting by OpenCV contrib's
// surface_matching module (cv::ppf_match_3d::PPF3DDetector), the only translation unit that
// includes it. The detector is trained once per model buffer; the scene is sampled and given
// normals with the module's own helpers.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/surface_matching.hpp>
#include <opencv2/surface_matching/ppf_helpers.hpp>

#include "GlobalRegistration3D.gen.hpp"
#include "cdff/types/cloud_extent.hpp"
#include "registration_common.hpp"

namespace cdff::dfn {
namespace {

/// A pose needs one reference and two more points to fix it.
constexpr int kFewestScenePoints = 3;
/// Fewer sampled model points than this describe no shape (PointPairVoting's bound).
constexpr std::size_t kFewestModelPoints = 10;
/// The most cells per side of the grid match() samples the scene on: the library allocates a
/// list per cell (128^3: 2 million, 50 MB, tens of milliseconds).
constexpr float kMostCellsPerSide = 128;
/// The fewest neighbours computeNormalsPC3d fits a plane to (noise wants more than 3).
constexpr int kFewestNormalNeighbours = 6;

/// The bounding box of an N x k CV_32F matrix's first three columns.
struct Box {
  cv::Vec2f x, y, z;
  float largestSide() const { return std::max({x[1] - x[0], y[1] - y[0], z[1] - z[0]}); }
  float smallestSide() const { return std::min({x[1] - x[0], y[1] - y[0], z[1] - z[0]}); }
};
Box boxOf(const cv::Mat& m) {
  Box b;
  b.x = cv::Vec2f(m.at<float>(0, 0), m.at<float>(0, 0));
  b.y = cv::Vec2f(m.at<float>(0, 1), m.at<float>(0, 1));
  b.z = cv::Vec2f(m.at<float>(0, 2), m.at<float>(0, 2));
  for (int i = 0; i < m.rows; ++i) {
    const float* r = m.ptr<float>(i);
    b.x = {std::min(b.x[0], r[0]), std::max(b.x[1], r[0])};
    b.y = {std::min(b.y[0], r[1]), std::max(b.y[1], r[1])};
    b.z = {std::min(b.z[0], r[2]), std::max(b.z[1], r[2])};
  }
  return b;
}

}  // namespace

class GlobalRegistration3DOpenCvPpf final : public GlobalRegistration3DOpenCvPpfBase {
 protected:
  Status onConfigure() override {
    CDFF_RETURN_IF_ERROR(global_registration::checkSampling(params_.sampling));
    detector_.reset();  // trained with the parameters: again on the next call
    return Status::ok();
  }

  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(prepare(*in.model));
    const PointCloud& scene = *in.scene;
    CDFF_RETURN_IF_ERROR(global_registration::checkScene(scene));
    CDFF_RETURN_IF_ERROR(checkModelScale(scene, sizes_.diameter, "scene", "model"));
    std::vector<global_registration::Cluster> clusters;
    int sampled_rows = 0;
    try {
      // Downsampled to cubes of d as the model was (the library's own sampling divides each
      // side of the bounding box into the same number of cells: anisotropic, and four times the
      // points on a scene deeper than it is wide).
      const cv::Mat sampled = sampleScene(scene);
      sampled_rows = sampled.rows;
      if (sampled.rows < kFewestScenePoints)
        return invalidInput(
            "input 'scene' has {} points after downsampling its {} points to {:.4g} m; expected "
            "at least {}",
            sampled.rows, scene.size(), sizes_.step, kFewestScenePoints);
      const cv::Vec3f viewpoint(static_cast<float>(params_.viewpoint[0]),
                                static_cast<float>(params_.viewpoint[1]),
                                static_cast<float>(params_.viewpoint[2]));
      cv::Mat oriented;
      if (scene.hasNormals()) {
        oriented = sampled.clone();
        for (int i = 0; i < oriented.rows; ++i) {  // towards the sensor, as the model's face it
          float* r = oriented.ptr<float>(i);
          const cv::Vec3f to_eye = viewpoint - cv::Vec3f(r[0], r[1], r[2]);
          if (r[3] * to_eye[0] + r[4] * to_eye[1] + r[5] * to_eye[2] < 0)
            for (int k = 3; k < 6; ++k) r[k] = -r[k];
        }
      } else {
        // The sampled points within normal_radius: about pi (normal_radius / d)^2 of them.
        const double ratio = sizes_.normal_radius / sizes_.step;
        const int neighbours = std::min(
            sampled.rows - 1,
            std::max(kFewestNormalNeighbours, static_cast<int>(std::lround(M_PI * ratio * ratio))));
        cv::ppf_match_3d::computeNormalsPC3d(sampled, oriented, neighbours, true, viewpoint);
      }
      // match() samples again: at half the step on the sample's own box, which keeps every point
      // of a sample whose points are about d apart; but the library allocates a list per cell
      // of that grid, so at most kMostCellsPerSide cells per side (a scene more than 30 m across
      // at d = 24 cm then merges some of its points).
      const Box sampled_box = boxOf(oriented);
      if (sampled_box.smallestSide() <= 0) {
        // The library divides by each side of the box (a crash on a zero one).
        warn(fmt::format(
            "input 'scene' has no extent along one axis after downsampling ({} points); OpenCV "
            "cannot sample it, so no hypothesis",
            oriented.rows));
        global_registration::publish({}, params_.max_hypotheses,
                                     static_cast<std::size_t>(sampled_rows), scene, *in.model, out);
        return Status::ok();
      }
      const float again = std::clamp(
          0.5f * static_cast<float>(sizes_.step) / std::max(sampled_box.largestSide(), 1e-6f),
          1.0f / kMostCellsPerSide, 1.0f);
      std::vector<cv::ppf_match_3d::Pose3DPtr> results;
      detector_->match(oriented, results, 1.0 / params_.reference_stride, again);
      for (const cv::ppf_match_3d::Pose3DPtr& r : results) {
        // The library also returns the poses of references no pair voted for; as
        // PointPairVoting, fewer than three agreeing votes is no pose.
        if (r->numVotes < 3) continue;
        global_registration::Cluster c;
        Eigen::Matrix4d m;
        for (int i = 0; i < 4; ++i)
          for (int j = 0; j < 4; ++j) m(i, j) = r->pose(i, j);
        c.scene_T_model.matrix() = m;
        c.votes = static_cast<double>(r->numVotes);
        if (c.scene_T_model.matrix().allFinite()) clusters.push_back(c);
      }
    } catch (const cv::Exception& e) {
      return numericalFailure("OpenCV's point pair feature matching failed: {}", e.what());
    }
    global_registration::publish(std::move(clusters), params_.max_hypotheses,
                                 static_cast<std::size_t>(sampled_rows), scene, *in.model, out);
    return Status::ok();
  }

 private:
  /// The scene's points per cube of d: with normals, per voxel and normal direction (N x 6),
  /// else the voxels' centroids (N x 3).
  cv::Mat sampleScene(const PointCloud& scene) {
    const auto step = static_cast<float>(sizes_.step);
    if (scene.hasNormals()) {
      global_registration::downsampleWithNormals(scene, step, runs_, oriented_);
      cv::Mat m(static_cast<int>(oriented_.size()), 6, CV_32F);
      for (int i = 0; i < m.rows; ++i)
        for (int k = 0; k < 3; ++k) {
          m.at<float>(i, k) = oriented_[static_cast<std::size_t>(i)].p[k];
          m.at<float>(i, 3 + k) = oriented_[static_cast<std::size_t>(i)].n[k];
        }
      return m;
    }
    runs_.build(scene, step);
    cv::Mat m(static_cast<int>(runs_.starts.size()) - 1, 3, CV_32F);
    for (int r = 0; r < m.rows; ++r) {
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      const std::uint32_t begin = runs_.starts[static_cast<std::size_t>(r)];
      const std::uint32_t end = runs_.starts[static_cast<std::size_t>(r) + 1];
      for (std::uint32_t k = begin; k < end; ++k) sum += scene.points[runs_.keyed[k].second].vec();
      sum /= static_cast<float>(end - begin);
      for (int k = 0; k < 3; ++k) m.at<float>(r, k) = sum[k];
    }
    return m;
  }

  /// Trains the detector when the model's buffers (or the parameters) changed since the last
  /// call.
  Status prepare(const PointCloud& model) {
    if (detector_ && model.points.data() == prepared_points_ &&
        model.normals.data() == prepared_normals_ && model.size() == prepared_size_)
      return Status::ok();
    detector_.reset();
    CDFF_RETURN_IF_ERROR(global_registration::checkModel(model));
    sizes_ =
        global_registration::sizesOf(params_.sampling, params_.cluster_distance,
                                     params_.normal_radius, global_registration::extentOf(model));
    // Trained on the model downsampled to cubes of d (as PointPairVoting's): the library's own
    // sampling divides each side of the bounding box into 1/sampling cells, so a model flatter
    // or thinner than it is long (a satellite with wings: 6 cm cells across a 24 cm step) keeps
    // four times the points, and its training, whose hash insert walks every entry of the same
    // feature (OpenCV 4.6), grows with their fourth power: minutes on the procedural targets.
    // Its sampling then keeps the downsampled points (cells at most d).
    std::vector<global_registration::Oriented> downsampled;
    global_registration::VoxelRuns runs;
    global_registration::downsampleWithNormals(model, static_cast<float>(sizes_.step), runs,
                                               downsampled);
    CDFF_RETURN_IF_ERROR(global_registration::checkDownsampledModel(
        downsampled.size(), kFewestModelPoints, sizes_, params_.sampling));
    const global_registration::ModelExtent extent = global_registration::extentOf(model);
    const Eigen::Vector3f sides = extent.max - extent.min;
    if (sides.minCoeff() <= 0)
      return invalidInput(
          "input 'model' spans {} x {} x {} m: no extent along one axis; expected a model OpenCV "
          "can sample (it divides each side of the bounding box into cells)",
          sides.x(), sides.y(), sides.z());
    try {
      cv::Mat points(static_cast<int>(downsampled.size()), 6, CV_32F);
      for (int i = 0; i < points.rows; ++i) {
        const global_registration::Oriented& o = downsampled[static_cast<std::size_t>(i)];
        float* row = points.ptr<float>(i);
        for (int k = 0; k < 3; ++k) {
          row[k] = o.p[k];
          row[3 + k] = o.n[k];
        }
      }
      auto detector = std::make_unique<cv::ppf_match_3d::PPF3DDetector>(
          params_.sampling, params_.sampling,
          std::round(360.0 / (params_.angle_step * 180.0 / M_PI)));
      detector->setSearchParams(sizes_.cluster_distance, params_.cluster_angle, true);
      detector->trainModel(points);
      detector_ = std::move(detector);
    } catch (const cv::Exception& e) {
      return numericalFailure("OpenCV's point pair feature training failed on input 'model': {}",
                              e.what());
    }
    prepared_points_ = model.points.data();
    prepared_normals_ = model.normals.data();
    prepared_size_ = model.size();
    return Status::ok();
  }

  std::unique_ptr<cv::ppf_match_3d::PPF3DDetector> detector_;
  const Point4f* prepared_points_ = nullptr;
  const Point4f* prepared_normals_ = nullptr;
  std::size_t prepared_size_ = 0;
  global_registration::Sizes sizes_;
  global_registration::VoxelRuns runs_;
  std::vector<global_registration::Oriented> oriented_;
};

CDFF_REGISTER_DFI(GlobalRegistration3DOpenCvPpf);

}  // namespace cdff::dfn
