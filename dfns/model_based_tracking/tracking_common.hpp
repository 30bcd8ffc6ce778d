#pragma once
// Shared by the ModelBasedTracking DFIs: where the model comes from, which images take part and
// how the status is published.

#include <memory>
#include <string>
#include <vector>

#include "ModelBasedTracking.gen.hpp"
#include "cdff/tracking/edge_tracker.hpp"
#include "cdff/tracking/prediction.hpp"

namespace cdff::dfn::mbt {

/// The model of this call: the `model` input when connected, else the one read from model_file.
class ModelSource {
 public:
  /// Reads `path` (a .cao file); an empty path clears the file model.
  Status load(const std::string& path) {
    file_model_.reset();
    if (path.empty()) return Status::ok();
    Result<PolygonModel> model = loadCao(path);
    if (!model) return model.status().withContext("parameter 'model_file'");
    file_model_ = std::make_shared<const PolygonModel>(std::move(model).value());
    file_ = path;
    return Status::ok();
  }

  /// The model to use and whether it differs from the previous call's.
  Result<std::shared_ptr<const PolygonModel>> select(const InputPort<PolygonModel>& input,
                                                     bool& changed) {
    std::shared_ptr<const PolygonModel> model = input.hasValue() ? input.shared() : file_model_;
    if (!model)
      return invalidInput("no model: expected the 'model' input or the parameter model_file");
    changed = model.get() != last_ || input.isFresh();
    last_ = model.get();
    return model;
  }
  const std::string& file() const { return file_; }
  /// The file model (null when none), taken as the one in use: a DFI that prepares it at
  /// configure time does not see it as changed at the first select().
  std::shared_ptr<const PolygonModel> useFileModel() {
    last_ = file_model_.get();
    return file_model_;
  }

 private:
  std::shared_ptr<const PolygonModel> file_model_;
  std::string file_;
  const PolygonModel* last_ = nullptr;
};

/// The cameras of this call, their grey images (owned here) and the reference frame.
struct Cameras {
  std::vector<Image> grey;  // one per camera; empty for a missing frame
  std::vector<tracking::CameraFrame> frames;
  bool stereo = false;
};

inline Result<Cameras> gatherCameras(const ModelBasedTracking::Inputs& in,
                                     const std::string& reference_frame) {
  Cameras out;
  if (in.image.hasValue() && in.stereo_images.hasValue())
    return invalidInput(
        "both 'image' and 'stereo_images' are set; expected one of them (mono or "
        "stereo tracking)");
  const auto addCamera = [&](const Image& image, const char* what, const Transform& extrinsics,
                             const CameraModel* fallback) -> Status {
    if (image.empty()) {  // a missing frame of this camera
      if (!fallback)
        return invalidInput(
            "{} is empty; expected an image (only one camera of a stereo pair "
            "may miss a frame)",
            what);
      out.grey.emplace_back();
      out.frames.push_back({nullptr, *fallback, extrinsics});
      return Status::ok();
    }
    if (!image.camera)
      return invalidInput("{} has no camera model; expected a calibrated, undistorted image", what);
    Result<Image> grey = tracking::toGray8(image, what);
    if (!grey) return grey.status();
    out.grey.push_back(std::move(grey).value());
    out.frames.push_back({nullptr, *image.camera, extrinsics});
    return Status::ok();
  };
  const Transform identity = Transform::identity(reference_frame, reference_frame);
  if (in.image.hasValue()) {
    CDFF_RETURN_IF_ERROR(addCamera(*in.image, "input 'image'", identity, nullptr));
  } else if (in.stereo_images.hasValue()) {
    const StereoImagePair& pair = *in.stereo_images;
    out.stereo = true;
    CDFF_RETURN_IF_ERROR(pair.right_T_left.validate().withContext("input 'stereo_images'"));
    if (pair.left.empty() && pair.right.empty())
      return invalidInput("input 'stereo_images' has two empty images; expected at least one");
    // Either camera may miss a frame: the other's calibration stands in for the missing one.
    const CameraModel* left_model = pair.left.camera ? &*pair.left.camera : nullptr;
    const CameraModel* right_model = pair.right.camera ? &*pair.right.camera : nullptr;
    if (!left_model && !right_model)
      return invalidInput(
          "input 'stereo_images' has no camera model; expected calibrated, "
          "undistorted images");
    const CameraModel left_fallback = left_model ? *left_model : *right_model;
    const CameraModel right_fallback = right_model ? *right_model : *left_model;
    CDFF_RETURN_IF_ERROR(
        addCamera(pair.left, "input 'stereo_images' left", identity, &left_fallback));
    const Transform right_T_left = Transform::fromIsometry(
        pair.right_T_left.isometry(),
        pair.right.frame_id.empty() ? std::string("right") : pair.right.frame_id, reference_frame,
        pair.right_T_left.stamp);
    CDFF_RETURN_IF_ERROR(
        addCamera(pair.right, "input 'stereo_images' right", right_T_left, &right_fallback));
  }
  for (std::size_t i = 0; i < out.frames.size(); ++i)
    out.frames[i].image = out.grey[i].empty() ? nullptr : &out.grey[i];
  return out;
}

/// The time of this call's measurements: the first image (or depth map) with a stamp; 0 if none.
inline Timestamp sensorStamp(const ModelBasedTracking::Inputs& in) {
  if (in.image.hasValue() && in.image->stamp != 0) return in.image->stamp;
  if (in.stereo_images.hasValue()) {
    if (!in.stereo_images->left.empty() && in.stereo_images->left.stamp != 0)
      return in.stereo_images->left.stamp;
    if (!in.stereo_images->right.empty() && in.stereo_images->right.stamp != 0)
      return in.stereo_images->right.stamp;
  }
  if (in.depth.hasValue()) return in.depth->image.stamp;
  return 0;
}

/// The prediction: `predicted_pose`, or the pose of `predicted_state` (EstimationFilter's output)
/// moved to the measurements' time with its twist (tracking::predictPose), so that the previous
/// frame's corrected state predicts this frame.
inline Result<PoseWithCovariance> prediction(const ModelBasedTracking::Inputs& in) {
  if (in.predicted_pose.hasValue() == in.predicted_state.hasValue())
    return invalidInput("{}; expected exactly one of 'predicted_pose' and 'predicted_state'",
                        in.predicted_pose.hasValue()
                            ? "both 'predicted_pose' and 'predicted_state' "
                              "are set"
                            : "no prediction");
  if (in.predicted_pose.hasValue()) {
    const PoseWithCovariance& p = *in.predicted_pose;
    CDFF_RETURN_IF_ERROR(p.validate().withContext("input 'predicted_pose'"));
    return p;
  }
  const RigidBodyState& state = *in.predicted_state;
  CDFF_RETURN_IF_ERROR(state.validate().withContext("input 'predicted_state'"));
  return tracking::predictPose(state, sensorStamp(in));
}

/// Publishes the status on both status outputs.
inline void publishStatus(ModelBasedTracking::Outputs& out, TrackingStatus status) {
  out.status.set(static_cast<int>(status));
  switch (status) {
    case TrackingStatus::kTracking:
      out.track_state.set(TrackState::kTracking);
      break;
    case TrackingStatus::kDegraded:
      out.track_state.set(TrackState::kDegraded);
      break;
    case TrackingStatus::kLost:
      out.track_state.set(TrackState::kLost);
      break;
  }
}

inline Result<Eigen::Isometry3d> depthExtrinsics(const std::vector<double>& values) {
  return tracking::isometryFromVector(values, "parameter 'depth_extrinsics'");
}

}  // namespace cdff::dfn::mbt
