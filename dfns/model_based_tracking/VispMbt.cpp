#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <optional>

#include <Eigen/Eigenvalues>

#include "ModelBasedTracking.gen.hpp"
#include "tracking_common.hpp"
#include "visp_mbt_bridge.hpp"

namespace cdff::dfn {

namespace {

visp_bridge::Matrix4 toMatrix4(const Eigen::Isometry3d& t) {
  visp_bridge::Matrix4 m{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[static_cast<std::size_t>(r * 4 + c)] = t.matrix()(r, c);
  return m;
}

Eigen::Isometry3d fromMatrix4(const visp_bridge::Matrix4& m) {
  Eigen::Matrix4d h;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) h(r, c) = m[static_cast<std::size_t>(r * 4 + c)];
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  // ViSP's matrices are orthonormal to double precision; re-normalise through a quaternion.
  t.linear() =
      Eigen::Quaterniond(Eigen::Matrix3d(h.topLeftCorner<3, 3>())).normalized().toRotationMatrix();
  t.translation() = h.topRightCorner<3, 1>();
  return t;
}

visp_bridge::Intrinsics intrinsicsOf(const CameraModel& c) {
  return {c.width, c.height, c.fx, c.fy, c.cx, c.cy};
}

bool sameIntrinsics(const visp_bridge::Intrinsics& a, const visp_bridge::Intrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy;
}

// ViSP's tracker needs at least one image, undistorted.
Status checkCameras(const mbt::Cameras& cameras) {
  if (cameras.frames.empty())
    return invalidInput("no 'image' or 'stereo_images'; ViSP's tracker needs at least one image");
  for (const tracking::CameraFrame& f : cameras.frames)
    if (f.camera.hasDistortion())
      return invalidInput(
          "an image has {} distortion; expected undistorted images (run "
          "ImageUndistortion first)",
          toString(f.camera.distortion_model));
  return Status::ok();
}

// The images handed to ViSP, one per camera. ViSP needs an image for every camera: a missing
// frame becomes a black one, kept in `black`.
struct ViewImages {
  std::vector<Image> black;
  std::vector<visp_bridge::GreyImage> grey;
};

ViewImages viewImages(const mbt::Cameras& cameras) {
  ViewImages out;
  for (const tracking::CameraFrame& f : cameras.frames) {
    const Image* image = f.image;
    if (!image) {
      std::vector<std::uint8_t> zeros(static_cast<std::size_t>(f.camera.width) * f.camera.height,
                                      0);
      out.black.push_back(
          Image::fromBytes(std::move(zeros), f.camera.width, f.camera.height, PixelFormat::kGray8)
              .value());
      image = &out.black.back();
    }
    out.grey.push_back({image->pixels.data(), image->width, image->height, image->stride_bytes});
  }
  return out;
}

// The depth map as ViSP takes it (metres per pixel, 0 where there is no measurement) and the
// depth camera in the rig.
struct DepthInput {
  std::vector<float> metres;
  int width = 0, height = 0;
  visp_bridge::Camera camera;
  visp_bridge::DepthImage image() const { return {metres.data(), width, height}; }
};

Result<DepthInput> depthInput(const DepthMap& depth, const Eigen::Isometry3d& depth_T_camera) {
  CDFF_RETURN_IF_ERROR(depth.validate().withContext("input 'depth'"));
  if (!depth.image.camera)
    return invalidInput(
        "input 'depth' has no camera model; expected the depth camera's "
        "intrinsics with the image");
  const Image& d = depth.image;
  DepthInput out;
  out.metres.resize(static_cast<std::size_t>(d.width) * d.height);
  for (int v = 0; v < d.height; ++v)
    for (int u = 0; u < d.width; ++u) {
      const double z = d.format == PixelFormat::kFloat32
                           ? d.at<float>(u, v) * depth.meters_per_unit
                           : d.at<std::uint16_t>(u, v) * depth.meters_per_unit;
      out.metres[static_cast<std::size_t>(v) * d.width + u] =
          std::isfinite(z) && z > 0 ? static_cast<float>(z) : 0.0f;
    }
  out.width = d.width;
  out.height = d.height;
  out.camera.intrinsics = intrinsicsOf(*d.camera);
  out.camera.camera_T_reference = toMatrix4(depth_T_camera);
  return out;
}

// Whether the model's bounding sphere at `prediction` reaches in front of a camera's near
// clipping plane: ViSP does not check it, and a prediction behind them all is a lost track
// before ViSP sees it.
struct Placement {
  bool in_front = false;
  double centre_z = 0;  // m, in the reference frame (for the message)
  double radius = 0;    // m
};

Placement placeModel(const PolygonModel& model, const std::vector<tracking::CameraFrame>& frames,
                     const Eigen::Isometry3d& prediction, double near_clipping) {
  const Eigen::AlignedBox3d box = model.bounds();
  Placement out;
  out.radius = 0.5 * box.diagonal().norm();
  for (const tracking::CameraFrame& f : frames)
    out.in_front = out.in_front ||
                   (f.camera_T_reference.isometry() * prediction * box.center()).z() + out.radius >
                       near_clipping;
  out.centre_z = (prediction * box.center()).z();
  return out;
}

// ViSP's covariance of the estimate in the conventions' parent-frame perturbation. ViSP updates
// cMo <- exp(v)^-1 cMo with the twist v = (nu, omega) of the camera: dt = -nu + [t]x omega,
// dtheta = -omega. Not finite: zero.
Matrix6d parentFrameCovariance(const std::array<double, 36>& visp,
                               const Eigen::Isometry3d& estimate) {
  Matrix6d visp_cov;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) visp_cov(r, c) = visp[static_cast<std::size_t>(r * 6 + c)];
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = -Eigen::Matrix3d::Identity();
  J.topRightCorner<3, 3>() = skew(estimate.translation());
  J.bottomRightCorner<3, 3>() = -Eigen::Matrix3d::Identity();
  Matrix6d covariance = J * visp_cov * J.transpose();
  covariance = (0.5 * (covariance + covariance.transpose())).eval();
  if (!covariance.allFinite()) covariance.setZero();
  // From features that leave a direction nearly unconstrained ViSP's matrix spans 12 orders of
  // magnitude and more (variances of 1e17 m^2 beside 1e6): rounding makes it indefinite. Its
  // eigenvalues are kept at least 1e-12 of the largest, so that it stays a covariance (a
  // positive-definite one, which a filter can take) that says as little as ViSP's.
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(covariance);
  const double largest = eigen.eigenvalues().maxCoeff();
  if (largest > 0 && eigen.eigenvalues().minCoeff() < 1e-12 * largest)
    covariance = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(1e-12 * largest).asDiagonal() *
                 eigen.eigenvectors().transpose();
  return covariance;
}

// The moving-edge settings, given for images `reference_width` wide, for images `width` wide:
// lengths in pixels times the width ratio, the mask to the nearest odd size (at least 3), and
// ViSP 3.5's likelihood threshold, a sum over the mask's pixels, times the mask's area ratio.
visp_bridge::Settings scaledToWidth(visp_bridge::Settings s, int reference_width, int width) {
  if (reference_width <= 0 || width == reference_width) return s;
  const double k = static_cast<double>(width) / reference_width;
  const int mask = std::max(3, 2 * static_cast<int>(std::lround((s.me_mask_size * k - 1) / 2)) + 1);
  s.me_threshold *= static_cast<double>(mask * mask) / (s.me_mask_size * s.me_mask_size);
  s.me_mask_size = mask;
  s.me_range = std::max(1, static_cast<int>(std::lround(s.me_range * k)));
  s.me_sample_step *= k;
  return s;
}

}  // namespace

class ModelBasedTrackingVispMbt final : public ModelBasedTrackingVispMbtBase {
 public:
  ~ModelBasedTrackingVispMbt() override { removeTemporaryModel(); }

 protected:
  Status onConfigure() override {
    const Parameters& p = params_;
    visp_bridge::Settings s;
    s.edges = p.mode != "klt";
    s.klt = p.mode == "klt" || p.mode == "edges_klt" || p.mode == "edges_klt_depth";
    s.me_mask_size = p.me_mask_size;
    s.me_mask_number = p.me_mask_number;
    s.me_range = p.me_range;
    s.me_threshold = p.me_threshold;
    s.me_mu1 = p.me_mu1;
    s.me_mu2 = p.me_mu2;
    s.me_sample_step = p.me_sample_step;
    s.klt_max_features = p.klt_max_features;
    s.klt_window_size = p.klt_window_size;
    s.klt_quality = p.klt_quality;
    s.klt_min_distance = p.klt_min_distance;
    s.klt_harris = p.klt_harris;
    s.klt_block_size = p.klt_block_size;
    s.klt_pyramid_levels = p.klt_pyramid_levels;
    s.klt_mask_border = p.klt_mask_border;
    s.depth_dense_step = p.depth_dense_step;
    s.angle_appear = p.angle_appear;
    s.angle_disappear = p.angle_disappear;
    s.near_clipping = p.near_clipping;
    s.far_clipping = p.far_clipping;
    s.fov_clipping = p.fov_clipping;
    s.scanline_visibility = p.scanline_visibility;
    if (p.angle_appear > p.angle_disappear)
      return invalidParameter(
          "angle_appear ({:.6g} deg) exceeds angle_disappear ({:.6g} deg); expected "
          "angle_appear <= angle_disappear",
          p.angle_appear / kRadiansPerDegree, p.angle_disappear / kRadiansPerDegree);
    if (p.near_clipping >= p.far_clipping)
      return invalidParameter("near_clipping ({} m) is not below far_clipping ({} m)",
                              p.near_clipping, p.far_clipping);
    Result<Eigen::Isometry3d> depth_T_camera = mbt::depthExtrinsics(p.depth_extrinsics);
    if (!depth_T_camera) return depth_T_camera.status();
    // Our parser first: its errors name the file and line, ViSP's do not.
    CDFF_RETURN_IF_ERROR(models_.load(p.model_file));
    wants_depth_ = p.mode == "edges_depth" || p.mode == "edges_klt_depth";
    s.covariance = p.covariance == "on" || (p.covariance == "auto" && !wants_depth_);
    settings_ = s;
    depth_T_camera_ = *depth_T_camera;
    configured_key_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    Result<PoseWithCovariance> predicted_input = mbt::prediction(in);
    if (!predicted_input) return predicted_input.status();
    const PoseWithCovariance& predicted = *predicted_input;
    bool model_changed = false;
    Result<std::shared_ptr<const PolygonModel>> model = models_.select(in.model, model_changed);
    if (!model) return model.status();
    CDFF_RETURN_IF_ERROR((*model)->validate("model"));
    Result<mbt::Cameras> cameras = mbt::gatherCameras(in, predicted.pose.parent_frame);
    if (!cameras) return cameras.status();
    CDFF_RETURN_IF_ERROR(checkCameras(*cameras));
    if (wants_depth_ && !in.depth.hasValue())
      return invalidInput("mode '{}' needs the 'depth' input; expected a depth map", params_.mode);

    const ViewImages images = viewImages(*cameras);
    for (std::size_t i = 0; i < images.black.size(); ++i)
      warn("a camera missed its frame: ViSP tracks on a black image in its place");
    DepthInput depth;
    if (wants_depth_) {
      Result<DepthInput> read = depthInput(*in.depth, depth_T_camera_);
      if (!read) return read.status();
      depth = std::move(read).value();
    }
    CDFF_RETURN_IF_ERROR(configureTracker(*model, model_changed, *cameras, depth.camera));

    const Eigen::Isometry3d prediction = predicted.pose.isometry();
    const Placement placement =
        placeModel(**model, cameras->frames, prediction, params_.near_clipping);
    if (!placement.in_front) {
      warn(
          fmt::format("lost: the predicted pose puts the model behind the camera (centre at z = "
                      "{:.3f} m, radius {:.3f} m)",
                      placement.centre_z, placement.radius));
      PoseWithCovariance lost = predicted;
      lost.covariance = tracking::noInformationCovariance();
      out.pose.set(std::move(lost));
      mbt::publishStatus(out, TrackingStatus::kLost);
      out.inlier_ratio.set(0.0);
      out.feature_count.set(0);
      return Status::ok();
    }
    CDFF_RETURN_IF_ERROR(seed(images.grey, prediction));

    visp_bridge::TrackOutput result;
    const visp_bridge::DepthImage depth_image = depth.image();
    const std::string error =
        tracker_.track(images.grey, wants_depth_ ? &depth_image : nullptr, result);
    publishEstimate(predicted, *cameras, error, result);
    return Status::ok();
  }

 private:
  struct Key {
    const PolygonModel* model = nullptr;
    std::vector<visp_bridge::Camera> cameras;
    bool depth = false;
    visp_bridge::Camera depth_camera;
    bool same(const Key& o) const {
      if (model != o.model || depth != o.depth || cameras.size() != o.cameras.size()) return false;
      for (std::size_t i = 0; i < cameras.size(); ++i)
        if (!sameIntrinsics(cameras[i].intrinsics, o.cameras[i].intrinsics) ||
            cameras[i].camera_T_reference != o.cameras[i].camera_T_reference)
          return false;
      return !depth || (sameIntrinsics(depth_camera.intrinsics, o.depth_camera.intrinsics) &&
                        depth_camera.camera_T_reference == o.depth_camera.camera_T_reference);
    }
  };

  // (Re)builds the ViSP tracker when the model or the rig changed.
  Status configureTracker(const std::shared_ptr<const PolygonModel>& model, bool model_changed,
                          const mbt::Cameras& cameras, const visp_bridge::Camera& depth_camera) {
    Key key;
    key.model = model.get();
    for (const tracking::CameraFrame& f : cameras.frames)
      key.cameras.push_back({intrinsicsOf(f.camera), toMatrix4(f.camera_T_reference.isometry())});
    key.depth = wants_depth_;
    if (wants_depth_) key.depth_camera = depth_camera;
    if (model_changed || !configured_key_ || !configured_key_->same(key)) {
      std::string path;
      if (in.model.hasValue() || models_.file().empty()) {
        Result<std::string> written = writeTemporaryModel(*model);
        if (!written) return written.status();
        path = *written;
      } else {
        path = models_.file();
      }
      const visp_bridge::Settings settings = scaledToWidth(settings_, params_.pixel_settings_width,
                                                           key.cameras.front().intrinsics.width);
      const std::string error =
          tracker_.configure(settings, key.cameras, wants_depth_ ? &depth_camera : nullptr, path);
      removeTemporaryModel();  // ViSP has read it
      if (!error.empty())
        return Status(StatusCode::kInvalidInput, fmt::format("model '{}': {}", path, error));
      configured_key_ = key;
    }
    return Status::ok();
  }

  // Seeds ViSP with the prediction unless it already holds that pose (its last estimate fed
  // back as the prediction).
  Status seed(const std::vector<visp_bridge::GreyImage>& images,
              const Eigen::Isometry3d& prediction) {
    const Eigen::Isometry3d current = fromMatrix4(tracker_.pose());
    const bool reseed =
        !tracker_.hasPose() || (current.translation() - prediction.translation()).norm() > 1e-6 ||
        Eigen::AngleAxisd(current.linear().transpose() * prediction.linear()).angle() > 1e-6;
    if (reseed) {
      const std::string error = tracker_.setPose(images, toMatrix4(prediction));
      if (!error.empty()) return Status(StatusCode::kInvalidInput, error);
    }
    return Status::ok();
  }

  // The outputs from ViSP's result: its estimate, or the prediction with no information when
  // it failed (`error`) or its inlier ratio is too low; degraded when a stereo camera missed
  // its frame.
  void publishEstimate(const PoseWithCovariance& predicted, const mbt::Cameras& cameras,
                       const std::string& error, const visp_bridge::TrackOutput& result) {
    TrackingStatus status = TrackingStatus::kTracking;
    PoseWithCovariance pose = predicted;
    pose.covariance = tracking::noInformationCovariance();  // until an estimate replaces it
    if (!error.empty()) {
      status = TrackingStatus::kLost;
      warn(fmt::format("lost: {}", error));
      configured_key_.reset();  // start afresh from the next prediction
    } else if (result.inlier_ratio < params_.min_inlier_ratio) {
      status = TrackingStatus::kLost;
      warn(fmt::format("lost: inlier ratio {:.2f} is below min_inlier_ratio {:.2f}",
                       result.inlier_ratio, params_.min_inlier_ratio));
    } else {
      const Eigen::Isometry3d estimate = fromMatrix4(result.reference_T_model);
      pose.pose = Transform::fromIsometry(estimate, predicted.pose.parent_frame,
                                          predicted.pose.child_frame, predicted.pose.stamp);
      for (const tracking::CameraFrame& f : cameras.frames)
        if (f.image && f.image->stamp != 0) {
          pose.pose.stamp = f.image->stamp;
          break;
        }
      pose.covariance = parentFrameCovariance(result.covariance, estimate);
      if (cameras.stereo && (!cameras.frames[0].image || !cameras.frames[1].image))
        status = TrackingStatus::kDegraded;
    }
    out.pose.set(std::move(pose));
    mbt::publishStatus(out, status);
    out.inlier_ratio.set(error.empty() ? result.inlier_ratio : 0.0);
    out.feature_count.set(error.empty() ? result.feature_count : 0);
  }

  // ViSP loads models from files: a model that came through the input is written as .cao.
  Result<std::string> writeTemporaryModel(const PolygonModel& model) {
    removeTemporaryModel();
    static std::atomic<int> counter{0};
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() /
        fmt::format("cdff_visp_model_{}_{}.cao", static_cast<long>(::getpid()), counter++);
    CDFF_RETURN_IF_ERROR(writeCao(model, path.string()));
    temporary_model_ = path.string();
    return temporary_model_;
  }
  void removeTemporaryModel() {
    if (temporary_model_.empty()) return;
    std::error_code ignored;
    std::filesystem::remove(temporary_model_, ignored);
    temporary_model_.clear();
  }

  visp_bridge::Settings settings_;
  bool wants_depth_ = false;
  Eigen::Isometry3d depth_T_camera_ = Eigen::Isometry3d::Identity();
  mbt::ModelSource models_;
  visp_bridge::MbtTracker tracker_;
  std::optional<Key> configured_key_;
  std::string temporary_model_;
};

CDFF_REGISTER_DFI(ModelBasedTrackingVispMbt);

}  // namespace cdff::dfn
